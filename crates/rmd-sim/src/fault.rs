//! Fault injection: seeded, reproducible, per motor and per frame type.
//!
//! A [`FaultRule`] says which motors ([`MotorSet`]), which frames ([`FrameFilter`]: a command,
//! the 0x280 multi-motor frame, or any), what goes wrong ([`FaultKind`]) and when ([`Window`]
//! plus a probability). Each rule draws from its own pseudo-random stream derived from the
//! simulation's seed and the rule's position, so the same seed and the same traffic give the
//! same faults, and adding a rule does not change what the others do.
//!
//! A kind is one fault of one of three levels, and each level has its own stage:
//! [`ReplyFault`] on the requests a motor receives, [`PhysicalFault`] on a motor's physics,
//! [`BusFault`] on the frames the host sends. Every stage matches its level exhaustively.
//!
//! | kind | evaluated | effect |
//! |---|---|---|
//! | [`DropReply`](ReplyFault::DropReply), [`LateReply`](ReplyFault::LateReply), [`CorruptBytes`](ReplyFault::CorruptBytes), [`WrongDlc`](ReplyFault::WrongDlc), [`DuplicateReply`](ReplyFault::DuplicateReply) | per matching request a motor receives | on that request's reply |
//! | [`Silent`](ReplyFault::Silent) | per matching request a motor receives | the motor ignores the request and sends nothing (as if unplugged; it keeps executing its last command) |
//! | [`LowVoltage`](PhysicalFault::LowVoltage), [`OverTemperature`](PhysicalFault::OverTemperature) | continuously, while the window is open (probability must be 1) | the physical cause: supply voltage forced down / winding held hot; the firmware raises its flag through its thresholds, and a clear cannot reset it while the cause lasts |
//! | [`BusOff`](BusFault::BusOff), [`TxStall`](BusFault::TxStall) | per matching frame the host sends (simulated bus only) | bus-off for `duration` / the host cannot transmit for `duration`, so its transmit queue fills |
//! | [`HostSilent`](BusFault::HostSilent) | per matching frame the host sends (simulated bus only) | from that frame on, nothing the host sends reaches the motors, and `send` still succeeds |
//!
//! Windows count frames per motor (the n-th matching request that motor received, from 0) for
//! reply and physical faults, and the host's matching frames for bus faults; a physical fault
//! with a frame window is on from the `from`-th matching frame until the `from + count`-th.

use core::time::Duration;

use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::{Rng, SeedableRng};
use rmd_bus::Timestamp;
use rmd_protocol::{Command, MotorId};

use crate::error::ConfigError;
use crate::physics::Environment;

mod kind;

pub use kind::{BusFault, FaultKind, PhysicalFault, ReplyFault};

/// A set of motor ids (1..=32).
///
/// ```
/// use rmd_protocol::MotorId;
/// use rmd_sim::MotorSet;
/// let m2 = MotorId::new(2).unwrap();
/// assert!(MotorSet::all().contains(m2));
/// assert!(MotorSet::only(m2).contains(m2));
/// assert!(!MotorSet::only(m2).contains(MotorId::new(3).unwrap()));
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct MotorSet(u32);

impl MotorSet {
    /// No motor.
    pub const NONE: Self = Self(0);
    /// Motors 1..=4, the ones a 0x280 frame drives.
    pub const MULTI_TORQUE: Self = Self(0b1111);

    /// Every motor.
    pub const fn all() -> Self {
        Self(u32::MAX)
    }

    /// One motor.
    pub const fn only(id: MotorId) -> Self {
        Self(1 << (id.get() - 1))
    }

    /// The listed motors.
    pub fn of(ids: &[MotorId]) -> Self {
        Self(ids.iter().fold(0, |acc, id| acc | (1 << (id.get() - 1))))
    }

    /// The set with `id` added.
    pub const fn with(self, id: MotorId) -> Self {
        Self(self.0 | 1 << (id.get() - 1))
    }

    /// Whether `id` is in the set.
    pub const fn contains(self, id: MotorId) -> bool {
        self.0 & (1 << (id.get() - 1)) != 0
    }

    /// Whether the set holds every motor.
    pub const fn is_all(self) -> bool {
        self.0 == u32::MAX
    }
}

/// Which frames a rule applies to (for motor faults: the request whose reply is affected).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum FrameFilter {
    /// Every frame.
    Any,
    /// Single-motor requests with this command byte.
    Command(Command),
    /// The 0x280 multi-motor torque frame (the motors' 0xA1 replies to it).
    MultiTorque,
}

/// The kind of request a host frame is, as fault rules match it ([`FrameFilter::matches`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum RequestKind {
    Single(Command),
    Multi,
    /// Not a valid request.
    Other,
}

impl FrameFilter {
    pub(crate) fn matches(self, kind: RequestKind) -> bool {
        match (self, kind) {
            (FrameFilter::Any, _) => true,
            (FrameFilter::Command(c), RequestKind::Single(k)) => c == k,
            (FrameFilter::MultiTorque, RequestKind::Multi) => true,
            (FrameFilter::Command(_), RequestKind::Multi | RequestKind::Other)
            | (FrameFilter::MultiTorque, RequestKind::Single(_) | RequestKind::Other) => false,
        }
    }
}

/// When a rule is active (before its probability is drawn).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Window {
    /// Always.
    Always,
    /// From the `from`-th matching frame (0-based) for `count` frames (`u64::MAX`: for ever).
    Frames {
        /// First matching frame, 0-based.
        from: u64,
        /// Number of matching frames.
        count: u64,
    },
    /// From `from` (inclusive) until `until` (exclusive), on the simulation's clock.
    Time {
        /// Start of the window.
        from: Timestamp,
        /// End of the window (exclusive).
        until: Timestamp,
    },
    /// The first `count` matching frames at or after `from` on the simulation's clock (one
    /// bus-off at a given instant, whatever the frame rate).
    FirstAfter {
        /// Start of the window.
        from: Timestamp,
        /// Number of matching frames.
        count: u64,
    },
}

impl Window {
    /// Whether the window holds the `frame_index`-th matching frame, at `at`, when
    /// `seen_after` matching frames were counted at or after a [`FirstAfter`](Window::FirstAfter)
    /// window's start before this one.
    fn contains(self, frame_index: u64, at: Timestamp, seen_after: u64) -> bool {
        match self {
            Window::Always => true,
            Window::Frames { from, count } => frame_index >= from && frame_index - from < count,
            Window::Time { from, until } => at >= from && at < until,
            Window::FirstAfter { from, count } => at >= from && seen_after < count,
        }
    }

    fn starts_by(self, at: Timestamp) -> bool {
        match self {
            Window::FirstAfter { from, .. } => at >= from,
            Window::Always | Window::Frames { .. } | Window::Time { .. } => false,
        }
    }
}

/// One fault-injection rule. Build it from its kind, then narrow it down.
///
/// ```
/// use core::time::Duration;
/// use rmd_protocol::{Command, MotorId};
/// use rmd_sim::{FaultRule, ReplyFault};
/// // Motor 2 drops 10 % of its replies to 0x9C.
/// let flaky = FaultRule::new(ReplyFault::DropReply)
///     .motor(MotorId::new(2).unwrap())
///     .command(Command::ReadStatus2)
///     .with_probability(0.1);
/// // Every 0x280 reply of every motor is 3 ms late from the 100th 0x280 frame on, for 5 frames.
/// let late = FaultRule::new(ReplyFault::LateReply { delay: Duration::from_millis(3) })
///     .multi_torque()
///     .frames_window(100, 5);
/// # let _ = (flaky, late);
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FaultRule {
    /// Which motors (for bus faults: the frames addressed to them; [`MotorSet::all`] also
    /// matches frames addressed to no motor).
    pub motors: MotorSet,
    /// Which frames.
    pub frames: FrameFilter,
    /// What goes wrong.
    pub kind: FaultKind,
    /// When.
    pub window: Window,
    /// Probability that an active window applies the fault to a given frame, 0..=1.
    pub probability: f64,
}

impl FaultRule {
    /// A rule for every motor and every frame, always, with probability 1; `kind` is a
    /// [`FaultKind`] or the fault of one level ([`ReplyFault`], [`PhysicalFault`], [`BusFault`]).
    pub fn new(kind: impl Into<FaultKind>) -> Self {
        Self {
            motors: MotorSet::all(),
            frames: FrameFilter::Any,
            kind: kind.into(),
            window: Window::Always,
            probability: 1.0,
        }
    }

    /// Only motor `id`.
    pub fn motor(mut self, id: MotorId) -> Self {
        self.motors = MotorSet::only(id);
        self
    }

    /// Only the motors of `set`.
    pub fn motors(mut self, set: MotorSet) -> Self {
        self.motors = set;
        self
    }

    /// Only frames matching `filter`.
    pub fn frames(mut self, filter: FrameFilter) -> Self {
        self.frames = filter;
        self
    }

    /// Only requests with command `command`.
    pub fn command(self, command: Command) -> Self {
        self.frames(FrameFilter::Command(command))
    }

    /// Only 0x280 multi-motor torque frames.
    pub fn multi_torque(self) -> Self {
        self.frames(FrameFilter::MultiTorque)
    }

    /// Active from the `from`-th matching frame (0-based) for `count` frames.
    pub fn frames_window(mut self, from: u64, count: u64) -> Self {
        self.window = Window::Frames { from, count };
        self
    }

    /// Active for the first `count` matching frames at or after `from`.
    pub fn first_after(mut self, from: Timestamp, count: u64) -> Self {
        self.window = Window::FirstAfter { from, count };
        self
    }

    /// Active from `from` (inclusive) until `until` (exclusive).
    pub fn during(mut self, from: Timestamp, until: Timestamp) -> Self {
        self.window = Window::Time { from, until };
        self
    }

    /// Applies to each frame of an active window with probability `p`.
    pub fn with_probability(mut self, p: f64) -> Self {
        self.probability = p;
        self
    }

    /// Checks the rule is meaningful; `index` is its position, for the error message.
    pub fn validate(&self, index: usize) -> Result<(), ConfigError> {
        let bad = |reason| Err(ConfigError::InvalidFaultRule { index, reason });
        if !(self.probability.is_finite() && (0.0..=1.0).contains(&self.probability)) {
            return bad("probability must be within 0..=1");
        }
        if !self.kind.is_drawn_per_frame() && self.probability != 1.0 {
            return bad(
                "a low-voltage or over-temperature cause is a window, not a per-frame draw: probability must be 1",
            );
        }
        if self.motors.0 == 0 {
            return bad("the rule selects no motor");
        }
        if let Window::Time { from, until } = self.window
            && until <= from
        {
            return bad("time window ends before it starts");
        }
        match self.kind.argument_error() {
            Some(reason) => bad(reason),
            None => Ok(()),
        }
    }
}

/// What the rules decided for one reply.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct ReplyFaults {
    pub(crate) silent: bool,
    pub(crate) drop: bool,
    pub(crate) late: Duration,
    /// Bytes to corrupt, with the random XOR values (0 = untouched).
    pub(crate) corrupt: [u8; 8],
    pub(crate) wrong_dlc: Option<u8>,
    pub(crate) duplicate: bool,
}

impl ReplyFaults {
    /// Adds `fault`, drawn by a rule whose stream is `rng`.
    fn add(&mut self, fault: ReplyFault, rng: &mut Pcg64Mcg) {
        match fault {
            ReplyFault::DropReply => self.drop = true,
            ReplyFault::LateReply { delay } => self.late = self.late.saturating_add(delay),
            ReplyFault::CorruptBytes { count } => corrupt(rng, count, &mut self.corrupt),
            ReplyFault::WrongDlc { dlc } => self.wrong_dlc = Some(dlc),
            ReplyFault::DuplicateReply => self.duplicate = true,
            ReplyFault::Silent => self.silent = true,
        }
    }
}

/// Index of the host's frame counter in [`RuleState::counts`].
const HOST: usize = 0;

/// One rule in the engine, its kind narrowed to the level `K` of the stage that evaluates it.
#[derive(Clone, Debug)]
struct RuleState<K> {
    kind: K,
    motors: MotorSet,
    frames: FrameFilter,
    window: Window,
    probability: f64,
    rng: Pcg64Mcg,
    /// Matching frames seen so far: index 0 the host's (bus faults), 1..=32 per motor.
    counts: [u64; 33],
    /// Matching frames counted at or after a [`Window::FirstAfter`]'s start, indexed as `counts`.
    after: [u64; 33],
}

impl<K> RuleState<K> {
    /// `rule`, of kind `kind` at its level, drawing from `rng`.
    fn new(kind: K, rule: &FaultRule, rng: Pcg64Mcg) -> Self {
        Self {
            kind,
            motors: rule.motors,
            frames: rule.frames,
            window: rule.window,
            probability: rule.probability,
            rng,
            counts: [0; 33],
            after: [0; 33],
        }
    }

    /// Whether a request of kind `kind` that `motor` received matches the rule.
    fn selects(&self, motor: MotorId, kind: RequestKind) -> bool {
        self.motors.contains(motor) && self.frames.matches(kind)
    }

    /// Counts a matching frame of counter `slot` at `at`; whether the window holds it.
    fn count(&mut self, slot: usize, at: Timestamp) -> bool {
        let n = self.counts[slot];
        self.counts[slot] = n.saturating_add(1);
        let seen_after = self.after[slot];
        if self.window.starts_by(at) {
            self.after[slot] = seen_after.saturating_add(1);
        }
        self.window.contains(n, at, seen_after)
    }

    fn draw(&mut self) -> bool {
        let p = self.probability;
        if p >= 1.0 {
            true
        } else if p <= 0.0 {
            false
        } else {
            unit(&mut self.rng) < p
        }
    }
}

/// A physical rule and, for a frame window, which motors have the cause on (bit id - 1).
#[derive(Clone, Debug)]
struct PhysicalRule {
    state: RuleState<PhysicalFault>,
    on: u32,
}

impl PhysicalRule {
    /// Whether the cause is on for `motor` at `at`.
    fn is_on(&self, motor: MotorId, at: Timestamp) -> bool {
        match self.state.window {
            Window::Always => true,
            Window::Time { from, until } => at >= from && at < until,
            Window::Frames { .. } | Window::FirstAfter { .. } => {
                self.on & (1 << (motor.get() - 1)) != 0
            }
        }
    }
}

/// A uniform draw in [0, 1) from the top 53 bits (value-stable across versions).
pub(crate) fn unit(rng: &mut Pcg64Mcg) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A pseudo-random generator for stream `stream` of the simulation seeded with `seed`.
pub(crate) fn stream(seed: u64, stream: u64) -> Pcg64Mcg {
    // SplitMix64 finalizer of seed and stream: independent, well-mixed starting points.
    let mut z = seed ^ stream.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Pcg64Mcg::seed_from_u64(z ^ (z >> 31))
}

/// The rules of one simulation and their state, each in the stage of its level.
#[derive(Clone, Debug, Default)]
pub(crate) struct FaultEngine {
    /// Evaluated on the requests a motor receives, in configuration order (a later rule's
    /// corrupted bytes avoid an earlier one's; the last wrong DLC wins).
    replies: Vec<RuleState<ReplyFault>>,
    /// Counted on the requests a motor receives, imposed on its physics.
    physical: Vec<PhysicalRule>,
    /// Evaluated on the frames the host sends, in configuration order (the first one that
    /// triggers on a frame starts).
    bus: Vec<RuleState<BusFault>>,
}

impl FaultEngine {
    /// Validates `rules`, seeds one stream per rule (from its position among all rules) and
    /// hands each to the stage of its level.
    pub(crate) fn new(rules: &[FaultRule], seed: u64) -> Result<Self, ConfigError> {
        let mut engine = Self::default();
        for (index, rule) in rules.iter().enumerate() {
            rule.validate(index)?;
            let rng = stream(seed, index as u64);
            match rule.kind {
                FaultKind::Reply(kind) => engine.replies.push(RuleState::new(kind, rule, rng)),
                FaultKind::Physical(kind) => engine.physical.push(PhysicalRule {
                    state: RuleState::new(kind, rule, rng),
                    on: 0,
                }),
                FaultKind::Bus(kind) => engine.bus.push(RuleState::new(kind, rule, rng)),
            }
        }
        Ok(engine)
    }

    /// Whether any rule is a bus fault (evaluated on host frames).
    pub(crate) fn has_bus_faults(&self) -> bool {
        !self.bus.is_empty()
    }

    /// Evaluates the motor-side rules for a request of kind `kind` that `motor` received at
    /// `at`: counts it, switches frame-window physical causes, draws the reply faults.
    pub(crate) fn on_motor_frame(
        &mut self,
        motor: MotorId,
        kind: RequestKind,
        at: Timestamp,
    ) -> ReplyFaults {
        let m = usize::from(motor.get());
        for rule in &mut self.physical {
            if !rule.state.selects(motor, kind) {
                continue;
            }
            let active = rule.state.count(m, at);
            match rule.state.window {
                Window::Frames { .. } | Window::FirstAfter { .. } => {
                    let bit = 1u32 << (m - 1);
                    if active {
                        rule.on |= bit;
                    } else {
                        rule.on &= !bit;
                    }
                }
                Window::Always | Window::Time { .. } => {}
            }
        }
        let mut out = ReplyFaults::default();
        for r in &mut self.replies {
            if r.selects(motor, kind) && r.count(m, at) && r.draw() {
                out.add(r.kind, &mut r.rng);
            }
        }
        out
    }

    /// Evaluates the bus rules for a frame the host sends at `at`, addressed to `motors`
    /// (`None`: to no motor). Returns the first bus fault that triggers.
    pub(crate) fn on_host_frame(
        &mut self,
        kind: RequestKind,
        motors: Option<MotorSet>,
        at: Timestamp,
    ) -> Option<BusFault> {
        let mut started = None;
        for r in &mut self.bus {
            if !r.frames.matches(kind) {
                continue;
            }
            let addressed = match motors {
                Some(set) => r.motors.0 & set.0 != 0,
                None => r.motors.is_all(),
            };
            if addressed && r.count(HOST, at) && r.draw() {
                started = started.or(Some(r.kind));
            }
        }
        started
    }

    /// The physical conditions imposed on `motor` at `at`.
    pub(crate) fn environment(&self, motor: MotorId, at: Timestamp) -> Environment {
        let mut env = Environment::default();
        for rule in &self.physical {
            if !rule.state.motors.contains(motor) || !rule.is_on(motor, at) {
                continue;
            }
            match rule.state.kind {
                PhysicalFault::LowVoltage { volts } => {
                    env.supply_voltage_override_v = Some(
                        env.supply_voltage_override_v
                            .map_or(volts, |v: f64| v.min(volts)),
                    )
                }
                PhysicalFault::OverTemperature { celsius } => {
                    env.temperature_floor_c = Some(
                        env.temperature_floor_c
                            .map_or(celsius, |t: f64| t.max(celsius)),
                    )
                }
            }
        }
        env
    }

    /// The first instant after `at` at which [`environment`](Self::environment) of `motor`
    /// can change by itself (a time window of a physical fault opening or closing).
    pub(crate) fn next_environment_change(
        &self,
        motor: MotorId,
        at: Timestamp,
    ) -> Option<Timestamp> {
        self.physical
            .iter()
            .filter(|rule| rule.state.motors.contains(motor))
            .filter_map(|rule| match rule.state.window {
                Window::Time { from, until } => [from, until].into_iter().find(|&t| t > at),
                Window::Always | Window::Frames { .. } | Window::FirstAfter { .. } => None,
            })
            .min()
    }
}

/// Chooses `count` distinct byte positions and a non-zero XOR value for each.
fn corrupt(rng: &mut Pcg64Mcg, count: u8, mask: &mut [u8; 8]) {
    let mut chosen = 0;
    while chosen < count.min(8) {
        let pos = (rng.next_u32() % 8) as usize;
        if mask[pos] != 0 {
            continue;
        }
        let value = (rng.next_u32() % 255) as u8 + 1;
        mask[pos] = value;
        chosen += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(id: u8) -> MotorId {
        MotorId::new(id).unwrap()
    }

    #[test]
    fn invalid_rules_are_rejected_with_their_index() {
        let rules = [
            FaultRule::new(ReplyFault::DropReply),
            FaultRule::new(ReplyFault::DropReply).with_probability(1.5),
        ];
        assert_eq!(
            FaultEngine::new(&rules, 1).unwrap_err(),
            ConfigError::InvalidFaultRule {
                index: 1,
                reason: "probability must be within 0..=1"
            }
        );
        for bad in [
            FaultRule::new(PhysicalFault::LowVoltage { volts: 10.0 }).with_probability(0.5),
            FaultRule::new(ReplyFault::WrongDlc { dlc: 8 }),
            FaultRule::new(ReplyFault::CorruptBytes { count: 0 }),
            FaultRule::new(ReplyFault::DropReply)
                .during(Timestamp::from_nanos(5), Timestamp::from_nanos(5)),
            FaultRule::new(ReplyFault::DropReply).motors(MotorSet::of(&[])),
        ] {
            assert!(bad.validate(0).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn frame_windows_count_matching_frames_per_motor() {
        let rule = FaultRule::new(ReplyFault::DropReply)
            .command(Command::ReadStatus2)
            .frames_window(2, 2);
        let mut engine = FaultEngine::new(&[rule], 7).unwrap();
        let t = Timestamp::ZERO;
        let s2 = RequestKind::Single(Command::ReadStatus2);
        let drops: Vec<bool> = (0..6)
            .map(|_| {
                // Other commands do not count.
                assert!(
                    !engine
                        .on_motor_frame(m(1), RequestKind::Single(Command::ReadStatus1), t)
                        .drop
                );
                engine.on_motor_frame(m(1), s2, t).drop
            })
            .collect();
        assert_eq!(drops, [false, false, true, true, false, false]);
        // Motor 2 has its own count.
        assert!(!engine.on_motor_frame(m(2), s2, t).drop);
    }

    #[test]
    fn probabilities_are_reproducible_per_seed() {
        let rule = FaultRule::new(ReplyFault::CorruptBytes { count: 3 }).with_probability(0.3);
        let run = |seed| {
            let mut e = FaultEngine::new(&[rule], seed).unwrap();
            (0..200)
                .map(|_| {
                    e.on_motor_frame(m(1), RequestKind::Multi, Timestamp::ZERO)
                        .corrupt
                })
                .collect::<Vec<_>>()
        };
        let (a, b, c) = (run(42), run(42), run(43));
        assert_eq!(a, b);
        assert_ne!(a, c);
        let hits = a.iter().filter(|mask| **mask != [0; 8]).count();
        assert!((30..=90).contains(&hits), "{hits} hits of 200 at p = 0.3");
        for mask in a.iter().filter(|mask| **mask != [0; 8]) {
            assert_eq!(mask.iter().filter(|&&b| b != 0).count(), 3);
        }
    }

    #[test]
    fn physical_causes_follow_their_windows() {
        let from = Timestamp::from_nanos(1_000);
        let until = Timestamp::from_nanos(2_000);
        let rules = [
            FaultRule::new(PhysicalFault::LowVoltage { volts: 20.0 })
                .motor(m(1))
                .during(from, until),
            FaultRule::new(PhysicalFault::OverTemperature { celsius: 95.0 })
                .motor(m(2))
                .command(Command::ReadStatus1)
                .frames_window(1, 1),
        ];
        let mut e = FaultEngine::new(&rules, 0).unwrap();
        assert_eq!(e.environment(m(1), Timestamp::ZERO), Environment::default());
        assert_eq!(
            e.environment(m(1), from).supply_voltage_override_v,
            Some(20.0)
        );
        assert_eq!(e.environment(m(1), until), Environment::default());
        assert_eq!(e.next_environment_change(m(1), Timestamp::ZERO), Some(from));
        assert_eq!(e.next_environment_change(m(1), from), Some(until));
        assert_eq!(e.next_environment_change(m(1), until), None);

        let k = RequestKind::Single(Command::ReadStatus1);
        e.on_motor_frame(m(2), k, Timestamp::ZERO);
        assert_eq!(
            e.environment(m(2), Timestamp::ZERO).temperature_floor_c,
            None
        );
        e.on_motor_frame(m(2), k, Timestamp::ZERO);
        assert_eq!(
            e.environment(m(2), Timestamp::ZERO).temperature_floor_c,
            Some(95.0)
        );
        e.on_motor_frame(m(2), k, Timestamp::ZERO);
        assert_eq!(
            e.environment(m(2), Timestamp::ZERO).temperature_floor_c,
            None
        );
    }

    /// Every kind of every level, with valid arguments.
    fn every_kind() -> Vec<FaultKind> {
        let ms = Duration::from_millis;
        let replies = [
            ReplyFault::DropReply,
            ReplyFault::LateReply { delay: ms(3) },
            ReplyFault::CorruptBytes { count: 3 },
            ReplyFault::WrongDlc { dlc: 5 },
            ReplyFault::DuplicateReply,
            ReplyFault::Silent,
        ];
        let physical = [
            PhysicalFault::LowVoltage { volts: 20.0 },
            PhysicalFault::OverTemperature { celsius: 95.0 },
        ];
        let bus = [
            BusFault::BusOff { duration: ms(10) },
            BusFault::TxStall { duration: ms(5) },
            BusFault::HostSilent,
        ];
        let replies = replies.into_iter().map(FaultKind::from);
        let physical = physical.into_iter().map(FaultKind::from);
        replies
            .chain(physical)
            .chain(bus.into_iter().map(FaultKind::from))
            .collect()
    }

    /// What one reply carries under `fault` alone, its corrupted bytes counted, not drawn.
    fn one_reply_under(fault: ReplyFault) -> (ReplyFaults, usize) {
        let mut expected = ReplyFaults::default();
        let mut corrupted = 0;
        match fault {
            ReplyFault::DropReply => expected.drop = true,
            ReplyFault::LateReply { delay } => expected.late = delay,
            ReplyFault::CorruptBytes { count } => corrupted = usize::from(count),
            ReplyFault::WrongDlc { dlc } => expected.wrong_dlc = Some(dlc),
            ReplyFault::DuplicateReply => expected.duplicate = true,
            ReplyFault::Silent => expected.silent = true,
        }
        (expected, corrupted)
    }

    /// The environment of a motor under `fault` alone.
    fn environment_under(fault: PhysicalFault) -> Environment {
        match fault {
            PhysicalFault::LowVoltage { volts } => Environment {
                supply_voltage_override_v: Some(volts),
                ..Environment::default()
            },
            PhysicalFault::OverTemperature { celsius } => Environment {
                temperature_floor_c: Some(celsius),
                ..Environment::default()
            },
        }
    }

    #[test]
    fn each_kind_acts_at_its_own_stage_only() {
        let t = Timestamp::ZERO;
        for kind in every_kind() {
            let mut e = FaultEngine::new(&[FaultRule::new(kind)], 3).unwrap();
            // Several frames of each sort, so a kind counted at the wrong stage would act.
            let mut at_motor = Vec::new();
            let mut at_host = Vec::new();
            for _ in 0..3 {
                at_motor.push(e.on_motor_frame(m(1), RequestKind::Multi, t));
                at_host.push(e.on_host_frame(RequestKind::Multi, None, t));
            }
            let env = e.environment(m(1), t);
            let (replies, physics, host) = match kind {
                FaultKind::Reply(fault) => {
                    let (expected, corrupted) = one_reply_under(fault);
                    for reply in &at_motor {
                        let bytes = reply.corrupt.iter().filter(|&&b| b != 0).count();
                        assert_eq!(bytes, corrupted, "{kind:?}");
                        let others = ReplyFaults {
                            corrupt: [0; 8],
                            ..*reply
                        };
                        assert_eq!(others, expected, "{kind:?}");
                    }
                    (true, false, false)
                }
                FaultKind::Physical(fault) => {
                    assert_eq!(env, environment_under(fault), "{kind:?}");
                    (false, true, false)
                }
                FaultKind::Bus(fault) => {
                    assert_eq!(at_host, [Some(fault); 3], "{kind:?}");
                    (false, false, true)
                }
            };
            if !replies {
                assert!(
                    at_motor.iter().all(|r| *r == ReplyFaults::default()),
                    "{kind:?} acted on a reply: {at_motor:?}"
                );
            }
            if !physics {
                assert_eq!(env, Environment::default(), "{kind:?} acted on the physics");
                assert_eq!(e.next_environment_change(m(1), t), None, "{kind:?}");
            }
            if !host {
                assert_eq!(at_host, [None; 3], "{kind:?} acted on a host frame");
            }
            assert_eq!(e.has_bus_faults(), host, "{kind:?}");
        }
    }

    #[test]
    fn bus_faults_trigger_on_host_frames() {
        let rule = FaultRule::new(BusFault::BusOff {
            duration: Duration::from_millis(10),
        })
        .multi_torque()
        .frames_window(3, 1);
        let mut e = FaultEngine::new(&[rule], 0).unwrap();
        assert!(e.has_bus_faults());
        let four = MotorSet::of(&[m(1), m(2), m(3), m(4)]);
        let got: Vec<_> = (0..5)
            .map(|_| e.on_host_frame(RequestKind::Multi, Some(four), Timestamp::ZERO))
            .collect();
        assert_eq!(
            got,
            [
                None,
                None,
                None,
                Some(BusFault::BusOff {
                    duration: Duration::from_millis(10)
                }),
                None
            ]
        );
        // Motor faults never fire on host frames, bus faults never on motor frames.
        assert_eq!(
            e.on_motor_frame(m(1), RequestKind::Multi, Timestamp::ZERO),
            ReplyFaults::default()
        );
    }

    #[test]
    fn a_first_after_window_takes_the_first_frames_at_or_after_its_start() {
        let at = |ms: u64| Timestamp::from_nanos(ms * 1_000_000);
        let rule = FaultRule::new(BusFault::TxStall {
            duration: Duration::from_millis(5),
        })
        .first_after(at(10), 2);
        let mut e = FaultEngine::new(&[rule], 0).unwrap();
        let got: Vec<bool> = [0, 9, 10, 11, 30, 40]
            .into_iter()
            .map(|ms| e.on_host_frame(RequestKind::Multi, None, at(ms)).is_some())
            .collect();
        assert_eq!(got, [false, false, true, true, false, false]);
        // Per motor, each motor's own first frames.
        let rule = FaultRule::new(ReplyFault::DropReply).first_after(at(10), 1);
        let mut e = FaultEngine::new(&[rule], 0).unwrap();
        let drops: Vec<bool> = [(1, 5), (1, 12), (2, 13), (1, 14), (2, 15)]
            .into_iter()
            .map(|(id, ms)| e.on_motor_frame(m(id), RequestKind::Multi, at(ms)).drop)
            .collect();
        assert_eq!(drops, [false, true, true, false, false]);
    }
}
