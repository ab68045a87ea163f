//! Deciding whether a logged frame is a request or a reply (`rmd decode --as auto`).
//!
//! Requests and replies share their CAN ID (0x140 + motor id), so a frame alone does not say
//! which it is. The rules, in order:
//!
//! 1. 0x280 is always a request (motors never send on it); it leaves a pending 0xA1 on
//!    0x141..=0x144.
//! 2. A candump direction marker decides when present: `TX` is a request. `RX` is a reply when
//!    the log comes from the host that sent the requests (it has `TX` frames); in a log where no
//!    `TX` has been seen yet (a listen-only host marks everything `RX`) rule 3 decides.
//! 3. Pairing: a frame is a reply if it follows a request with the same command byte on the same
//!    ID that has not been answered yet (0x9A also answers a pending 0x9B); otherwise it is a
//!    request.
//!
//! A request leaves its command byte pending on its ID, even if its fields fail to decode (so
//! that its reply is still recognised); a reply clears it.

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

/// Pairing state over one log.
#[derive(Debug, Default)]
pub(crate) struct Pairing {
    /// Pending (unanswered) request command byte per CAN ID.
    pending: HashMap<u16, u8>,
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
                self.pending
                    .insert(FIRST_MOTOR_CAN_ID + offset, Command::Torque.code());
            }
            return Role::Request;
        }
        let code = data.first().copied();
        let pending = self.pending.get(&can_id).copied();
        let answers_pending = match (pending, code) {
            (Some(p), Some(c)) => {
                p == c || (p == Command::ClearError.code() && c == Command::ReadStatus1.code())
            }
            _ => false,
        };
        let is_reply = match marker {
            Some(Direction::Tx) => false,
            Some(Direction::Rx) if self.seen_tx => true,
            _ => answers_pending,
        };
        if is_reply {
            self.pending.remove(&can_id);
            let pending_command = if answers_pending {
                pending.and_then(Command::from_code)
            } else {
                None
            };
            Role::Reply(pending_command)
        } else {
            match code {
                Some(c) => {
                    self.pending.insert(can_id, c);
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
        assert_eq!(p.classify(0x141, &[0x9C], None), Role::Request);
        // Another ID, another command: both requests.
        assert_eq!(p.classify(0x142, &[0x9C], None), Role::Request);
        assert_eq!(p.classify(0x141, &[0x9A], None), Role::Request);
        // 0x141 now waits for 0x9A: a 0x9C is a new request.
        assert_eq!(p.classify(0x141, &[0x9C], None), Role::Request);
        assert_eq!(
            p.classify(0x141, &[0x9C], None),
            Role::Reply(Some(Command::ReadStatus2))
        );
        assert_eq!(
            p.classify(0x142, &[0x9C], None),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // Answered: the next 0x9C is a request again.
        assert_eq!(p.classify(0x141, &[0x9C], None), Role::Request);
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
}
