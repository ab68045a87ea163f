//! The live view of `rmd monitor` on a terminal, without the terminal: what the keys do
//! ([`View::key`]), the readings kept for the plots ([`History`]), and the screen drawn into
//! any ratatui backend ([`draw`]: a plot per motor of the chosen signal with its last value,
//! minimum and maximum, the table of every reading below, the keys at the bottom).

use ratatui::Frame;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Borders, Chart, Dataset, GraphType, Paragraph};

/// How much of the past a plot shows, seconds.
pub(crate) const WINDOW_S: f64 = 30.0;

/// The signals a plot can show.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Signal {
    /// The multi-turn angle (with a robot: the joint angle), degrees.
    Angle,
    /// The motor's speed, degrees per second.
    Speed,
    /// The torque current, amperes.
    Current,
    /// The motor's temperature, degrees Celsius.
    Temperature,
}

impl Signal {
    const ALL: [Signal; 4] = [
        Signal::Angle,
        Signal::Speed,
        Signal::Current,
        Signal::Temperature,
    ];

    fn index(self) -> usize {
        self as usize
    }

    /// The next signal (Tab), around.
    fn next(self) -> Self {
        Self::ALL[(self.index() + 1) % Self::ALL.len()]
    }

    /// The previous signal (Shift-Tab), around.
    fn previous(self) -> Self {
        Self::ALL[(self.index() + Self::ALL.len() - 1) % Self::ALL.len()]
    }

    /// Its name and unit, for titles.
    pub(crate) fn label(self) -> &'static str {
        match self {
            Signal::Angle => "angle °",
            Signal::Speed => "speed dps",
            Signal::Current => "current A",
            Signal::Temperature => "temperature °C",
        }
    }
}

/// One reading of one motor, in the units of [`Signal`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Sample {
    /// Seconds since the monitor started.
    pub(crate) time_s: f64,
    /// Angle, speed, current, temperature, in [`Signal`] order.
    pub(crate) values: [f64; 4],
}

/// The most readings a plot keeps (at high `--rate`s the window is shorter than [`WINDOW_S`]):
/// a plot a few hundred cells wide shows no more, and a frame stays cheap to draw.
pub(crate) const CAPACITY: usize = 2048;

/// The readings of one motor over the last [`WINDOW_S`] seconds (at most [`CAPACITY`]): a ring
/// buffer, allocated once, whose oldest readings make room for new ones.
#[derive(Clone, Debug)]
pub(crate) struct History {
    samples: std::collections::VecDeque<Sample>,
}

impl Default for History {
    fn default() -> Self {
        Self {
            samples: std::collections::VecDeque::with_capacity(CAPACITY),
        }
    }
}

/// What a plot says about its signal: the last value, the least and the greatest in the window.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Extent {
    pub(crate) last: f64,
    pub(crate) min: f64,
    pub(crate) max: f64,
}

impl History {
    /// Adds a reading; forgets those older than the window, and the oldest beyond
    /// [`CAPACITY`].
    pub(crate) fn push(&mut self, sample: Sample) {
        if self.samples.len() == CAPACITY {
            self.samples.pop_front();
        }
        self.samples.push_back(sample);
        while self
            .samples
            .front()
            .is_some_and(|s| s.time_s < sample.time_s - WINDOW_S)
        {
            self.samples.pop_front();
        }
    }

    /// The points of `signal`, (time, value).
    pub(crate) fn points(&self, signal: Signal) -> Vec<(f64, f64)> {
        self.samples
            .iter()
            .map(|s| (s.time_s, s.values[signal.index()]))
            .collect()
    }

    /// Last, least and greatest value of `signal` in the window; `None` before a reading.
    pub(crate) fn extent(&self, signal: Signal) -> Option<Extent> {
        let last = self.samples.back()?.values[signal.index()];
        let (min, max) = self
            .samples
            .iter()
            .map(|s| s.values[signal.index()])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        Some(Extent { last, min, max })
    }
}

/// What a key asks for.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Action {
    /// Redraw (the view changed) or nothing to do.
    Redraw,
    /// End the monitor.
    Quit,
}

/// The view's state: which signal, which motor is selected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct View {
    pub(crate) signal: Signal,
    pub(crate) selected: usize,
    motors: usize,
}

impl View {
    /// The angle plot, the first of `motors` motors selected.
    pub(crate) fn new(motors: usize) -> Self {
        Self {
            signal: Signal::Angle,
            selected: 0,
            motors,
        }
    }

    /// Applies one key: `a`/`s`/`c`/`t` choose angle, speed, current, temperature; Tab and
    /// Shift-Tab go through them; the arrows (or `j`/`k`) select the next or previous motor,
    /// `1`..`9` a motor by its place; `q`, Esc and Ctrl-C quit.
    pub(crate) fn key(&mut self, key: KeyEvent) -> Action {
        let ctrl = key.modifiers.contains(KeyModifiers::CONTROL);
        match key.code {
            KeyCode::Char('c') if ctrl => return Action::Quit,
            KeyCode::Char('q') | KeyCode::Esc => return Action::Quit,
            KeyCode::Char('a') => self.signal = Signal::Angle,
            KeyCode::Char('s') => self.signal = Signal::Speed,
            KeyCode::Char('c') => self.signal = Signal::Current,
            KeyCode::Char('t') => self.signal = Signal::Temperature,
            KeyCode::Tab => self.signal = self.signal.next(),
            KeyCode::BackTab => self.signal = self.signal.previous(),
            KeyCode::Right | KeyCode::Down | KeyCode::Char('j') if self.motors > 0 => {
                self.selected = (self.selected + 1) % self.motors;
            }
            KeyCode::Left | KeyCode::Up | KeyCode::Char('k') if self.motors > 0 => {
                self.selected = (self.selected + self.motors - 1) % self.motors;
            }
            KeyCode::Char(d @ '1'..='9') => {
                let place = d as usize - '1' as usize;
                if place < self.motors {
                    self.selected = place;
                }
            }
            _ => {}
        }
        Action::Redraw
    }
}

/// Everything one frame shows.
pub(crate) struct Screen<'a> {
    /// The top line (bus, time, readings).
    pub(crate) title: String,
    /// Each motor's label (`motor 3`, `knee`) and history, in table order.
    pub(crate) motors: Vec<(String, &'a History)>,
    /// The table of the last reading, line by line.
    pub(crate) table: Vec<String>,
}

/// Each plot's rows at least (the frame, the title, a few rows of plot).
const PLOT_ROWS: u16 = 7;

/// The motors whose plots fit in `rows` rows, a run of them that includes the selected one.
fn visible(motors: usize, selected: usize, rows: u16) -> std::ops::Range<usize> {
    let fit = usize::from((rows / PLOT_ROWS).max(1)).min(motors);
    let first = selected.saturating_sub(fit - 1).min(motors - fit);
    first..first + fit
}

/// Draws `screen` as `view` says.
pub(crate) fn draw(frame: &mut Frame<'_>, view: &View, screen: &Screen<'_>) {
    let table_rows = u16::try_from(screen.table.len()).unwrap_or(u16::MAX);
    let [title, plots, table, keys] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(PLOT_ROWS),
        Constraint::Length(table_rows),
        Constraint::Length(1),
    ])
    .areas(frame.area());
    frame.render_widget(
        Paragraph::new(Line::from(vec![
            Span::styled(
                screen.title.clone(),
                Style::default().add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!("   plotting: {}", view.signal.label())),
        ])),
        title,
    );
    if !screen.motors.is_empty() {
        let shown = visible(screen.motors.len(), view.selected, plots.height);
        let areas = Layout::vertical(vec![Constraint::Fill(1); shown.len()]).split(plots);
        for (area, index) in areas.iter().zip(shown) {
            let (label, history) = &screen.motors[index];
            plot(
                frame,
                *area,
                label,
                history,
                view.signal,
                index == view.selected,
            );
        }
    }
    frame.render_widget(Paragraph::new(screen.table.join("\n")), table);
    frame.render_widget(
        Paragraph::new(
            "a angle  s speed  c current  t temperature  Tab next  ←/→ motor  1-9 motor  q quit",
        )
        .style(Style::default().fg(Color::DarkGray)),
        keys,
    );
}

/// `value` with two decimals, never `-0.00`.
fn number(value: f64) -> String {
    let text = format!("{value:.2}");
    match text.strip_prefix('-') {
        Some(magnitude) if magnitude.bytes().all(|b| b == b'0' || b == b'.') => {
            magnitude.to_owned()
        }
        _ => text,
    }
}

/// One motor's plot of `signal`, titled with its last value, minimum and maximum.
fn plot(
    frame: &mut Frame<'_>,
    area: Rect,
    label: &str,
    history: &History,
    signal: Signal,
    selected: bool,
) {
    let title = match history.extent(signal) {
        Some(e) => format!(
            " {label}: {}  last {}  min {}  max {} ",
            signal.label(),
            number(e.last),
            number(e.min),
            number(e.max)
        ),
        None => format!(" {label}: {}  no reading yet ", signal.label()),
    };
    let border = if selected {
        Style::default()
            .fg(Color::Yellow)
            .add_modifier(Modifier::BOLD)
    } else {
        Style::default()
    };
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(border)
        .title(title);
    let points = history.points(signal);
    let (t_end, extent) = match (points.last(), history.extent(signal)) {
        (Some(&(t, _)), Some(extent)) => (t, extent),
        _ => {
            frame.render_widget(block, area);
            return;
        }
    };
    let t_start = (t_end - WINDOW_S).max(0.0);
    // A flat signal still gets a band to be drawn in.
    let pad = ((extent.max - extent.min) * 0.1).max(0.5);
    let (low, high) = (extent.min - pad, extent.max + pad);
    let dataset = Dataset::default()
        .marker(symbols::Marker::Braille)
        .graph_type(GraphType::Line)
        .style(Style::default().fg(if selected { Color::Yellow } else { Color::Cyan }))
        .data(&points);
    let chart = Chart::new(vec![dataset])
        .block(block)
        .x_axis(Axis::default().bounds([t_start, t_end.max(t_start + 1.0)]))
        .y_axis(
            Axis::default()
                .bounds([low, high])
                .labels([format!("{low:.1}"), format!("{high:.1}")]),
        );
    frame.render_widget(chart, area);
}

#[cfg(test)]
mod tests {
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    use super::*;

    fn press(view: &mut View, code: KeyCode) -> Action {
        view.key(KeyEvent::new(code, KeyModifiers::NONE))
    }

    #[test]
    fn keys_choose_the_signal_and_the_motor() {
        let mut view = View::new(3);
        assert_eq!(view.signal, Signal::Angle);
        press(&mut view, KeyCode::Char('c'));
        assert_eq!(view.signal, Signal::Current);
        press(&mut view, KeyCode::Tab);
        assert_eq!(view.signal, Signal::Temperature);
        press(&mut view, KeyCode::Tab);
        assert_eq!(view.signal, Signal::Angle, "Tab goes around");
        press(&mut view, KeyCode::BackTab);
        assert_eq!(view.signal, Signal::Temperature);
        press(&mut view, KeyCode::Char('s'));
        assert_eq!(view.signal, Signal::Speed);

        press(&mut view, KeyCode::Right);
        press(&mut view, KeyCode::Right);
        assert_eq!(view.selected, 2);
        press(&mut view, KeyCode::Right);
        assert_eq!(view.selected, 0, "the arrows go around");
        press(&mut view, KeyCode::Left);
        assert_eq!(view.selected, 2);
        press(&mut view, KeyCode::Char('2'));
        assert_eq!(view.selected, 1);
        press(&mut view, KeyCode::Char('9'));
        assert_eq!(
            view.selected, 1,
            "a motor that is not there changes nothing"
        );
        assert_eq!(press(&mut view, KeyCode::Char('x')), Action::Redraw);

        assert_eq!(press(&mut view, KeyCode::Char('q')), Action::Quit);
        assert_eq!(press(&mut view, KeyCode::Esc), Action::Quit);
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(view.key(ctrl_c), Action::Quit);
        // No motors: moving the selection is harmless.
        let mut empty = View::new(0);
        press(&mut empty, KeyCode::Right);
        assert_eq!(empty.selected, 0);
    }

    fn sample(time_s: f64, angle: f64) -> Sample {
        Sample {
            time_s,
            values: [angle, 10.0 * angle, -0.5, 30.0],
        }
    }

    #[test]
    fn a_history_keeps_the_window_and_knows_its_extent() {
        let mut h = History::default();
        assert_eq!(h.extent(Signal::Angle), None);
        // Times in quarter seconds: exact in binary, so the window's edge is exact too.
        for k in 0..160 {
            let t = f64::from(k) * 0.25;
            h.push(sample(t, (t * 0.5).sin() * 20.0));
        }
        // 40 s of readings at 4 Hz: the last 30 s (and the one at its edge) are kept.
        let points = h.points(Signal::Angle);
        assert_eq!(points.len(), 121);
        assert_eq!((points[0].0, points[120].0), (9.75, 39.75));
        let e = h.extent(Signal::Angle).unwrap();
        assert!(
            e.min > -20.0 && e.min < -19.9 && e.max > 19.9 && e.max <= 20.0,
            "{e:?}"
        );
        assert_eq!(e.last, (39.75_f64 * 0.5).sin() * 20.0);
        let speed = h.extent(Signal::Speed).unwrap();
        assert!((speed.max - 10.0 * e.max).abs() < 1e-9);
        assert_eq!(h.extent(Signal::Temperature).unwrap().min, 30.0);
    }

    #[test]
    fn a_fast_history_keeps_the_newest_readings_up_to_its_capacity() {
        let mut h = History::default();
        let n = u32::try_from(CAPACITY).unwrap() + 500;
        for k in 0..n {
            // 1 kHz: all within the window, more than the capacity.
            h.push(sample(f64::from(k) * 0.001, f64::from(k)));
        }
        let points = h.points(Signal::Angle);
        assert_eq!(points.len(), CAPACITY);
        assert_eq!(points[0].1, 500.0, "the oldest went first");
        let e = h.extent(Signal::Angle).unwrap();
        assert_eq!(
            (e.min, e.max, e.last),
            (500.0, f64::from(n - 1), f64::from(n - 1))
        );
    }

    #[test]
    fn numbers_have_two_decimals_and_no_negative_zero() {
        assert_eq!(number(-0.0), "0.00");
        assert_eq!(number(-0.001), "0.00");
        assert_eq!(number(-0.005_1), "-0.01");
        assert_eq!(number(12.345_6), "12.35");
        assert_eq!(number(-9.8), "-9.80");
    }

    #[test]
    fn visible_plots_always_include_the_selected_motor() {
        assert_eq!(visible(4, 0, 70), 0..4);
        assert_eq!(visible(8, 0, 21), 0..3);
        assert_eq!(visible(8, 6, 21), 4..7);
        assert_eq!(visible(8, 7, 21), 5..8);
        assert_eq!(visible(2, 1, 3), 1..2, "at least one plot");
    }

    /// The screen's text, line by line.
    fn text(terminal: &Terminal<TestBackend>) -> Vec<String> {
        let buffer = terminal.backend().buffer();
        let area = buffer.area;
        (0..area.height)
            .map(|y| {
                (0..area.width)
                    .map(|x| buffer[(x, y)].symbol())
                    .collect::<String>()
            })
            .collect()
    }

    #[test]
    fn the_screen_has_a_titled_plot_per_motor_the_table_and_the_keys() {
        let mut knee = History::default();
        let mut hip = History::default();
        for k in 0..50 {
            let t = f64::from(k) * 0.1;
            knee.push(sample(t, t));
            hip.push(sample(t, -2.0 * t));
        }
        let screen = Screen {
            title: "rmd monitor: the simulated bus  t 4.90 s".to_owned(),
            motors: vec![("knee".to_owned(), &knee), ("hip".to_owned(), &hip)],
            table: vec![
                "joint  temp °C  volts".to_owned(),
                " knee       30   48.0".to_owned(),
            ],
        };
        let mut view = View::new(2);
        let mut terminal = Terminal::new(TestBackend::new(100, 30)).unwrap();
        terminal.draw(|f| draw(f, &view, &screen)).unwrap();
        let lines = text(&terminal);
        let all = lines.join("\n");
        assert!(
            lines[0].starts_with("rmd monitor: the simulated bus  t 4.90 s"),
            "{all}"
        );
        assert!(lines[0].contains("plotting: angle °"), "{all}");
        assert!(
            all.contains("knee: angle °  last 4.90  min 0.00  max 4.90"),
            "{all}"
        );
        assert!(
            all.contains("hip: angle °  last -9.80  min -9.80  max 0.00"),
            "{all}"
        );
        // The plot drew something (Braille dots) inside the frames.
        assert!(
            all.chars().any(|c| ('\u{2801}'..='\u{28ff}').contains(&c)),
            "{all}"
        );
        assert_eq!(
            lines[27],
            "joint  temp °C  volts".to_owned() + &" ".repeat(79)
        );
        assert!(lines[28].starts_with(" knee       30   48.0"));
        assert!(
            lines[29].starts_with("a angle  s speed  c current"),
            "{all}"
        );

        // Another signal: the titles follow.
        view.key(KeyEvent::new(KeyCode::Char('t'), KeyModifiers::NONE));
        terminal.draw(|f| draw(f, &view, &screen)).unwrap();
        let all = text(&terminal).join("\n");
        assert!(
            all.contains("knee: temperature °C  last 30.00  min 30.00  max 30.00"),
            "{all}"
        );
        assert!(text(&terminal)[0].contains("plotting: temperature °C"));
    }

    #[test]
    fn a_motor_without_readings_says_so() {
        let empty = History::default();
        let screen = Screen {
            title: "rmd monitor".to_owned(),
            motors: vec![("motor 3".to_owned(), &empty)],
            table: Vec::new(),
        };
        let mut terminal = Terminal::new(TestBackend::new(60, 12)).unwrap();
        terminal.draw(|f| draw(f, &View::new(1), &screen)).unwrap();
        assert!(
            text(&terminal)
                .join("\n")
                .contains("motor 3: angle °  no reading yet")
        );
    }
}
