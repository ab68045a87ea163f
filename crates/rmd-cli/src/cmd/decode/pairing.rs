//! Deciding whether a logged frame is a request or a reply (`rmd decode --as auto`).
//!
//! Requests and replies share their CAN ID (0x140 + motor id), so a frame alone does not say
//! which it is. The rules, in order:
//!
//! 1. 0x280 is always a request (motors never send on it); it leaves a pending 0xA1 on
//!    0x141..=0x144.
//! 2. A candump direction marker decides when present, whatever the frame holds: `TX` is a
//!    request. `RX` is a reply when the log comes from the host that sent the requests (it has
//!    `TX` frames); in a log where no `TX` has been seen yet (a listen-only host, such as
//!    `rmd log`, marks everything `RX`, requests included) rule 3 decides.
//! 3. Pairing: a frame is a reply if it follows a request with the same command byte on the same
//!    ID that has not been answered yet (0x9A also answers a pending 0x9B); otherwise it is a
//!    request. Except: **a frame identical to the pending request of a read command** (0x30,
//!    0x33, 0x90, 0x92, 0x94, 0x9A, 0x9B, 0x9C, 0x9D: requests without data, replies with
//!    readings) is another request, not its reply: on a shared bus the log shows other
//!    programs' queries too, and query, query, reply must read as request, request, reply.
//!
//! The one ambiguity left: a motor whose true reply to a read command is all zeros (0x9D with
//! no phase current, 0x92 at exactly 0°, 0x90 with encoder, raw position and offset 0, ...) sends
//! a frame identical to the request, and rule 3 takes it for another request. Only direction
//! markers (a log recorded by the host that sent the requests: `rmd ... --log FILE`,
//! `candump -L -x`) tell the two apart.
//!
//! A request leaves its command byte (and its bytes) pending on its ID, even if its fields fail
//! to decode (so that its reply is still recognised); a reply clears it.

use std::collections::HashMap;

use rmd_bus::candump::Direction;
use rmd_protocol::{Command, FIRST_MOTOR_CAN_ID, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS};

/// What a frame was classified as.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    /// Sent by the host.
    Request,
    /// Sent by a motor; with the pending request it answers, if known.
    Reply(Option<Command>),
}

/// The commands whose request carries no data and whose reply carries readings: a frame
/// identical to such a pending request is another request (see the module docs).
const READS: [Command; 9] = [
    Command::ReadPid,
    Command::ReadAccel,
    Command::ReadEncoder,
    Command::ReadMultiTurnAngle,
    Command::ReadSingleTurnAngle,
    Command::ReadStatus1,
    Command::ClearError,
    Command::ReadStatus2,
    Command::ReadStatus3,
];

/// A request waiting for its reply on one CAN ID.
#[derive(Clone, Debug)]
struct Pending {
    /// Its command byte.
    code: u8,
    /// Its data bytes; `None` for the 0xA1 a 0x280 frame leaves pending.
    data: Option<Vec<u8>>,
}

impl Pending {
    /// Whether a frame with `code` answers this request (0x9A also answers 0x9B).
    fn answered_by(&self, code: u8) -> bool {
        self.code == code
            || (self.code == Command::ClearError.code() && code == Command::ReadStatus1.code())
    }

    /// Whether `data` repeats this request of a read command byte for byte.
    fn repeated_by(&self, data: &[u8]) -> bool {
        self.data.as_deref() == Some(data) && READS.iter().any(|c| c.code() == self.code)
    }
}

/// Pairing state over one log.
#[derive(Debug, Default)]
pub(crate) struct Pairing {
    /// Pending (unanswered) request per CAN ID.
    pending: HashMap<u16, Pending>,
    /// Whether a `TX` marker has been seen.
    seen_tx: bool,
}

impl Pairing {
    /// Classifies the next frame of the log and updates the state.
    pub(crate) fn classify(&mut self, can_id: u16, data: &[u8], marker: Option<Direction>) -> Role {
        if marker == Some(Direction::Tx) {
            self.seen_tx = true;
        }
        if can_id == MULTI_TORQUE_CAN_ID {
            for offset in 0..MULTI_TORQUE_MOTORS as u16 {
                self.pending.insert(
                    FIRST_MOTOR_CAN_ID + offset,
                    Pending {
                        code: Command::Torque.code(),
                        data: None,
                    },
                );
            }
            return Role::Request;
        }
        let code = data.first().copied();
        let pending = self.pending.get(&can_id);
        let answers_pending = matches!((pending, code), (Some(p), Some(c)) if p.answered_by(c));
        let repeats_pending = pending.is_some_and(|p| p.repeated_by(data));
        let is_reply = match marker {
            Some(Direction::Tx) => false,
            Some(Direction::Rx) if self.seen_tx => true,
            _ => answers_pending && !repeats_pending,
        };
        if is_reply {
            let pending = self.pending.remove(&can_id);
            let pending_command = if answers_pending {
                pending.and_then(|p| Command::from_code(p.code))
            } else {
                None
            };
            Role::Reply(pending_command)
        } else {
            match code {
                Some(code) => {
                    self.pending.insert(
                        can_id,
                        Pending {
                            code,
                            data: Some(data.to_vec()),
                        },
                    );
                }
                None => {
                    self.pending.remove(&can_id);
                }
            }
            Role::Request
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A1: [u8; 8] = [0xA1, 0, 0, 0, 0, 0, 0, 0];

    #[test]
    fn pairs_by_command_byte_on_the_same_id() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        // Another ID, another command: both requests.
        assert_eq!(p.classify(0x142, &Q9C, None), Role::Request);
        assert_eq!(p.classify(0x141, &[0x9A], None), Role::Request);
        // 0x141 now waits for 0x9A: a 0x9C is a new request.
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        assert_eq!(
            p.classify(0x141, &R9C, None),
            Role::Reply(Some(Command::ReadStatus2))
        );
        assert_eq!(
            p.classify(0x142, &R9C, None),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // Answered: the next 0x9C is a request again.
        assert_eq!(p.classify(0x141, &R9C, None), Role::Request);
    }

    #[test]
    fn multi_torque_expects_a1_replies_from_motors_1_to_4() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x280, &[0; 8], None), Role::Request);
        for id in 0x141..=0x144 {
            assert_eq!(
                p.classify(id, &A1, None),
                Role::Reply(Some(Command::Torque))
            );
        }
        assert_eq!(p.classify(0x145, &A1, None), Role::Request);
    }

    #[test]
    fn status1_answers_clear_error() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &[0x9B], None), Role::Request);
        assert_eq!(
            p.classify(0x141, &[0x9A], None),
            Role::Reply(Some(Command::ClearError))
        );
    }

    #[test]
    fn markers_decide_when_the_log_has_tx() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &A1, Some(Direction::Tx)), Role::Request);
        assert_eq!(
            p.classify(0x141, &A1, Some(Direction::Rx)),
            Role::Reply(Some(Command::Torque))
        );
        // A reply whose request was not logged: still a reply, with no pending command.
        assert_eq!(
            p.classify(0x141, &[0x9C], Some(Direction::Rx)),
            Role::Reply(None)
        );
        // A lost reply: the next TX is a request even though the same command is pending.
        assert_eq!(p.classify(0x142, &A1, Some(Direction::Tx)), Role::Request);
        assert_eq!(p.classify(0x142, &A1, Some(Direction::Tx)), Role::Request);
    }

    #[test]
    fn listen_only_logs_fall_back_to_pairing() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &A1, Some(Direction::Rx)), Role::Request);
        assert_eq!(
            p.classify(0x141, &A1, Some(Direction::Rx)),
            Role::Reply(Some(Command::Torque))
        );
    }

    const Q9C: [u8; 8] = [0x9C, 0, 0, 0, 0, 0, 0, 0];
    const R9C: [u8; 8] = [0x9C, 30, 0, 0, 0, 0, 0, 0x10];

    #[test]
    fn a_repeated_read_request_is_another_request() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        assert_eq!(
            p.classify(0x141, &R9C, None),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // A query with other reserved bytes is not identical: it is taken as the reply.
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        let mut other = Q9C;
        other[7] = 1;
        assert_eq!(
            p.classify(0x141, &other, None),
            Role::Reply(Some(Command::ReadStatus2))
        );
    }

    #[test]
    fn repeated_write_and_control_frames_are_still_replies() {
        // 0x80 and 0x31 replies echo their request byte for byte: identical is the reply.
        for frame in [
            [0x80, 0, 0, 0, 0, 0, 0, 0],
            [0x31, 0, 100, 100, 50, 40, 50, 50],
            A1,
        ] {
            let mut p = Pairing::default();
            assert_eq!(p.classify(0x143, &frame, None), Role::Request);
            assert!(matches!(
                p.classify(0x143, &frame, None),
                Role::Reply(Some(_))
            ));
        }
    }

    #[test]
    fn an_all_zero_reply_is_the_ambiguity_left() {
        // A motor at rest answers 0x9D with no phase current: `9D 00 .. 00`, identical to the
        // request, so unmarked it reads as another request...
        let q9d = [0x9D, 0, 0, 0, 0, 0, 0, 0];
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x142, &q9d, None), Role::Request);
        assert_eq!(p.classify(0x142, &q9d, None), Role::Request);
        // ...and markers from the sending host tell it apart.
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x142, &q9d, Some(Direction::Tx)), Role::Request);
        assert_eq!(
            p.classify(0x142, &q9d, Some(Direction::Rx)),
            Role::Reply(Some(Command::ReadStatus3))
        );
    }

    #[test]
    fn markers_win_over_the_repeat_rule() {
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &Q9C, Some(Direction::Tx)), Role::Request);
        // RX in a log with TX: the reply, even though identical to the request.
        assert_eq!(
            p.classify(0x141, &Q9C, Some(Direction::Rx)),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // TX: a request, even though it answers the pending command.
        assert_eq!(p.classify(0x141, &Q9C, Some(Direction::Tx)), Role::Request);
        assert_eq!(p.classify(0x141, &R9C, Some(Direction::Tx)), Role::Request);
    }
}
