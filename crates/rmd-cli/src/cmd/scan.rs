//! `rmd scan`: which motor ids answer on the bus, and the protocol family each one speaks.
//!
//! Every id is probed with 0x9A and 0x9C on `0x140 + id`, listening on `0x140 + id` and
//! `0x240 + id` ([`Connection::identify`]); `rmd_protocol::identify` names the family from the
//! answers (`v1.61`, `lk-v2.3x`, `myactuator-v3` or `unknown`), and a V3 motor is asked its
//! model (0xB5) and firmware date (0xB2). The status 1 of each motor is shown in its family's
//! layout.

use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use rmd_protocol::{
    Command, Dialect, Finding, FirmwareDate, Identification, LkSeries, ProbeAnswers,
    ProtocolFamily, Reply, Status1, V3Firmware,
};
use serde_json::{Map, Value, json};

use crate::args::bus::BusArgs;
use crate::args::ids::{self, IdList};
use crate::live::connect::Connection;
use crate::output::json::reply_fields;
use crate::output::progress::{self, Progress};
use crate::output::readings;
use crate::output::report::{self, CliError};
use crate::output::table::{Align, TextTable};
use crate::output::{errln, out, outln};

/// Arguments of `rmd scan`.
#[derive(Args, Debug)]
#[command(
    after_help = "Each id is probed with 0x9A and 0x9C (read-only in every family) on 0x140 + id; \
    answers are collected on 0x140 + id and 0x240 + id. The firmware column names the protocol \
    family: v1.61, lk-v2.3x (0x9A with LK-TECH's layout), myactuator-v3 (answers on 0x240 + id; \
    its model is read with 0xB5, its firmware date with 0xB2) or unknown. --json: one array, an \
    object per motor that answered: id, firmware, model and firmware_date (V3), ambiguous, \
    evidence {reply_id, answered_status1, answered_status2, finding, v161_volts, lk_volts}, then \
    its status 1 under rmd decode's names."
)]
pub(crate) struct ScanArgs {
    /// Ids to try.
    #[arg(long, value_name = "IDS", value_parser = ids::parse, default_value = "1-32")]
    ids: IdList,
    /// Print one JSON array of the motors that answered (firmware, evidence, status 1).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    bus: BusArgs,
}

/// A scan waits this long per id by default (absent ids cost the whole timeout).
const SCAN_TIMEOUT: Duration = Duration::from_millis(20);

/// A motor that answered: its identification, status 1 and (V3) firmware date, if read.
struct Found {
    identification: Identification,
    status1: Option<Status1>,
    firmware_date: Option<FirmwareDate>,
}

/// Runs `rmd scan`.
pub(crate) fn run(args: ScanArgs) -> ExitCode {
    report::exit(scan(&args))
}

fn scan(args: &ScanArgs) -> Result<(), CliError> {
    let mut bus = Connection::open(&args.bus, SCAN_TIMEOUT, 0)?;
    let mut found = Vec::new();
    let progress = Progress::counter(
        args.ids.ids().len() as u64,
        "ids",
        progress::shown(args.json),
    );
    progress.set_prefix("scan ");
    for (done, &motor) in args.ids.ids().iter().enumerate() {
        progress.set_position(done as u64);
        progress.set_message(format!("found {}", found.len()));
        let identified = bus.identify(motor)?;
        let identification = identified.identification;
        if identification.evidence.reply_id.is_some() {
            found.push(Found {
                status1: status1(&identification, &identified.answers),
                identification,
                firmware_date: identified.firmware_date,
            });
        }
    }
    drop(progress);
    let setup = bus.setup().clone();
    bus.finish()?;
    for motor in &found {
        let id = &motor.identification;
        if id.family == ProtocolFamily::Unknown || ambiguous(id) {
            errln!("warning: {id}");
        }
    }
    if args.json {
        let list = found.iter().map(json_object).collect();
        outln!("{}", Value::Array(list))?;
    } else if !found.is_empty() {
        out!("{}", table(&found).render())?;
    }
    if found.is_empty() {
        return Err(CliError::Failed(format!(
            "no motor answered on {} (ids {}): check that the motors are powered and wired, \
             and that the interface runs at their bit rate (1 Mbit/s by default); raise \
             --timeout-ms if the adapter is slow",
            setup.name(),
            args.ids
        )));
    }
    let ids: Vec<String> = found
        .iter()
        .map(|m| m.identification.motor.to_string())
        .collect();
    errln!(
        "{} motor{} answered on {}: {}",
        found.len(),
        if found.len() == 1 { "" } else { "s" },
        setup.name(),
        ids.join(", ")
    );
    Ok(())
}

/// Whether both readings of 0x9A were plausible (the family was chosen by DATA\[2\]).
fn ambiguous(id: &Identification) -> bool {
    matches!(id.evidence.finding, Finding::BothReadingsPlausible { .. })
}

/// The 0x9A answer decoded in the identified family's layout, if it decodes.
fn status1(id: &Identification, answers: &ProbeAnswers) -> Option<Status1> {
    let frame = answers.status1()?;
    let dialect = match id.family {
        ProtocolFamily::V161 => Dialect::V161,
        // The series changes only current scales, which status 1 does not carry.
        ProtocolFamily::LkV23x => Dialect::LkV23x(LkSeries::Mg),
        // Status 1 is the same in every V3 firmware (V4.3 §2.14, V4.4 §2.13).
        ProtocolFamily::MyActuatorV3 => Dialect::MyActuatorV3(V3Firmware::default()),
        ProtocolFamily::Unknown => return None,
    };
    dialect
        .decode_reply_to(&frame, Command::ReadStatus1)
        .ok()
        .and_then(|(_, reply)| reply.status1())
}

/// One motor's JSON object: id, firmware, model, ambiguous, evidence, then status 1.
fn json_object(motor: &Found) -> Value {
    let id = &motor.identification;
    let evidence = &id.evidence;
    let mut map = Map::new();
    map.insert("id".into(), json!(id.motor.get()));
    map.insert("firmware".into(), json!(id.family.name()));
    if let Some(model) = evidence.model_str() {
        map.insert("model".into(), json!(model));
    }
    if let Some(date) = motor.firmware_date {
        map.insert("firmware_date".into(), json!(date.raw()));
        map.insert(
            "firmware_revision".into(),
            json!(date.revision().to_string()),
        );
    }
    map.insert("ambiguous".into(), json!(ambiguous(id)));
    let mut facts = Map::new();
    if let Some(reply_id) = evidence.reply_id {
        facts.insert("reply_id".into(), json!(format!("0x{reply_id:03X}")));
    }
    facts.insert("answered_status1".into(), json!(evidence.answered_status1));
    facts.insert("answered_status2".into(), json!(evidence.answered_status2));
    facts.insert("finding".into(), json!(evidence.finding.to_string()));
    if let Some(readings) = evidence.status1 {
        facts.insert("v161_volts".into(), json!(readings.v161_volts));
        facts.insert("lk_volts".into(), json!(readings.lk_volts));
    }
    map.insert("evidence".into(), Value::Object(facts));
    if let Some(status) = &motor.status1 {
        map.extend(reply_fields(
            &Reply::ReadStatus1(*status),
            rmd_protocol::EncoderWidth::DEFAULT,
        ));
    }
    Value::Object(map)
}

/// The table of the motors found.
fn table(found: &[Found]) -> TextTable {
    let mut table = TextTable::new(&[
        ("id", Align::Right),
        ("firmware", Align::Left),
        ("temperature", Align::Right),
        ("voltage", Align::Right),
        ("errors", Align::Left),
        ("note", Align::Left),
    ]);
    for motor in found {
        let id = &motor.identification;
        let (temperature, voltage, errors) = match &motor.status1 {
            Some(s) => (
                format!("{} °C", s.temperature().celsius()),
                format!("{:.1} V", s.volts()),
                readings::status1_errors_text(s),
            ),
            None => dashes(),
        };
        let note = match id.family {
            ProtocolFamily::MyActuatorV3 => {
                let model = id
                    .evidence
                    .model_str()
                    .map(|model| format!("model {model}"));
                let firmware = motor
                    .firmware_date
                    .map(|date| format!("firmware {date} ({})", date.revision()));
                [model, firmware]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>()
                    .join(", ")
            }
            ProtocolFamily::Unknown => id.evidence.finding.to_string(),
            _ if ambiguous(id) => id.evidence.finding.to_string(),
            _ => String::new(),
        };
        table.row([
            id.motor.get().to_string(),
            id.family.name().to_owned(),
            temperature,
            voltage,
            errors,
            note,
        ]);
    }
    table
}

fn dashes() -> (String, String, String) {
    ("-".to_owned(), "-".to_owned(), "-".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_protocol::{CanFrame, MotorId, identify};

    fn found(frames: &[[u8; 8]]) -> Found {
        let motor = MotorId::new(3).unwrap();
        let mut answers = ProbeAnswers::new();
        for data in frames {
            answers.offer(motor, &CanFrame::new(0x143, data).unwrap());
        }
        let identification = identify(motor, &answers);
        Found {
            status1: status1(&identification, &answers),
            identification,
            firmware_date: None,
        }
    }

    #[test]
    fn an_unknown_motor_is_listed_with_its_evidence_and_no_status() {
        // Answered 0x9C only: it is there, its family cannot be told.
        let motor = found(&[[0x9C, 30, 0, 0, 0, 0, 0, 0x10]]);
        let value = json_object(&motor);
        assert_eq!(value["firmware"], "unknown");
        assert_eq!(value["evidence"]["answered_status1"], false);
        assert_eq!(
            value["evidence"]["finding"],
            "no answer to 0x9A, which tells v1.61 from LK-TECH"
        );
        assert!(value.get("voltage_volts").is_none());
        let rendered = table(&[motor]).render();
        assert!(rendered.contains("unknown"), "{rendered}");
        assert!(rendered.contains("no answer to 0x9A"), "{rendered}");
    }

    #[test]
    fn an_ambiguous_answer_is_marked() {
        // v1.61 at 26.0 V (0x0104 in DATA[3..=4]) also reads as LK at 10.24 V; DATA[2] = 0
        // chose v1.61.
        let motor = found(&[[0x9A, 30, 0, 0x04, 0x01, 0, 0, 0]]);
        let value = json_object(&motor);
        assert_eq!(value["firmware"], "v1.61");
        assert_eq!(value["ambiguous"], true);
        assert_eq!(value["voltage_volts"], 26.0);
        assert_eq!(value["evidence"]["lk_volts"], 10.24);
        assert!(table(&[motor]).render().contains("ambiguous"));
    }

    #[test]
    fn a_v3_motor_shows_its_model_and_firmware_date() {
        let motor = MotorId::new(2).unwrap();
        let mut answers = ProbeAnswers::new();
        answers.offer(
            motor,
            &CanFrame::new(0x242, &[0x9A, 30, 31, 0, 0xE0, 1, 0x04, 0]).unwrap(),
        );
        answers.offer(
            motor,
            &CanFrame::new(0x242, &[0xB5, b'X', b'8', b'S', b'2', b'V', b'1', b'0']).unwrap(),
        );
        let identification = identify(motor, &answers);
        let found = Found {
            status1: status1(&identification, &answers),
            identification,
            firmware_date: Some(FirmwareDate::from_raw(2_026_042_402)),
        };
        let value = json_object(&found);
        assert_eq!(value["firmware"], "myactuator-v3");
        assert_eq!(value["model"], "X8S2V10");
        assert_eq!(value["firmware_date"], 2_026_042_402);
        assert_eq!(value["firmware_revision"], "V4.4");
        assert_eq!(value["voltage_volts"], 48.0);
        let rendered = table(&[found]).render();
        assert!(rendered.contains("low voltage"), "{rendered}");
        assert!(
            rendered.contains("model X8S2V10, firmware 2026042402 (V4.4)"),
            "{rendered}"
        );
    }
}
