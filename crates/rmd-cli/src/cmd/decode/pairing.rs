//! Deciding whether a logged frame is a request or a reply (`rmd decode --as auto`, and the host's
//! frames of `rmd replay`).
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
//!    request.
//!
//! [`Pairing::classify`] decides each frame at once by these rules (`rmd replay` uses it to pick
//! the host's frames). [`LookAhead`], which `rmd decode` uses, adds one exception to rule 3: **a
//! frame identical to the pending request of a read command** (0x30, 0x33, 0x90, 0x92, 0x94,
//! 0x9A, 0x9B, 0x9C, 0x9D: requests without data, replies with readings) is another request when
//! the reply follows it: on a shared bus a log shows other programs' queries too, and query,
//! query, reply must read as request, request, reply. Such a frame may also be a true reply: a
//! motor at rest answers some reads with all zeros (0x9D without phase current, 0x92 at exactly
//! 0°, 0x90 at encoder, raw position and offset 0). So a run of frames identical to a pending
//! read request is held until the next frame on its ID: if that frame is the reply (with data)
//! to the same command, every frame of the run was a request; otherwise (another command, a
//! marker-decided request, the end of the log, or [`HELD_LINES`] later lines without a decision)
//! the run alternates reply, request, reply, ... (query, all-zero reply).
//!
//! The ambiguity left: an all-zero reply followed on its ID by another query of the same command
//! and that query's reply with data (query, zero reply, query, reply) reads as three requests and
//! a reply; and a query nobody answered followed by an identical query and then another command
//! reads as request and reply. Only direction markers (a log recorded by the host that sent the
//! requests: `rmd ... --log FILE`, `candump -L -x`) tell these apart.
//!
//! A request leaves its command byte (and its bytes) pending on its ID, even if its fields fail
//! to decode (so that its reply is still recognised); a reply clears it.

use std::collections::{BTreeMap, HashMap};

use rmd_bus::candump::FrameDirection;
use rmd_protocol::{
    Command, FIRST_MOTOR_CAN_ID, MULTI_TORQUE_CAN_ID, MULTI_TORQUE_MOTORS, MotorId,
    SINGLE_MOTOR_BASE_ID, V3_MOTION_REPLY_BASE_ID, V3_REPLY_BASE_ID,
};

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
    /// Classifies the next frame of the log at once by rules 1 to 3 without the exception for
    /// repeated queries (a frame identical to the pending request is its reply), and updates the
    /// state. [`LookAhead`] adds the exception.
    pub(crate) fn classify(
        &mut self,
        can_id: u16,
        data: &[u8],
        marker: Option<FrameDirection>,
    ) -> Role {
        if marker == Some(FrameDirection::Tx) {
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
        let is_reply = match marker {
            Some(FrameDirection::Tx) => false,
            Some(FrameDirection::Rx) if self.seen_tx => true,
            _ => answers_pending,
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

/// Pairing on a MyActuator V3 bus, where the identifier says the direction: requests on
/// `0x140 + id`, 0x280 (every motor) and `0x400 + id` (motion mode), replies on `0x240 + id`
/// and `0x500 + id`. A host may send a motor several requests before the replies (`rmd`
/// identifies a motor with 0x9A and 0x9C at once): a reply pairs with the oldest unanswered
/// request to its motor with the same command byte, or else with the last request, whose
/// command it then does not match, an error (a V3 motor answers a command it does not know with
/// its previous reply). At most [`V3_PENDING`] requests per motor wait; older ones are dropped.
#[derive(Debug, Default)]
pub(crate) struct V3Pairing {
    /// The command bytes waiting for their replies, oldest first, per reply identifier
    /// (`0x240 + id`).
    pending: HashMap<u16, Vec<u8>>,
}

/// How many unanswered requests per motor [`V3Pairing`] keeps.
const V3_PENDING: usize = 8;

impl V3Pairing {
    /// Classifies the next frame and updates the state.
    pub(crate) fn classify(&mut self, can_id: u16, data: &[u8]) -> Role {
        let per_motor = |base: u16| {
            can_id
                .checked_sub(base)
                .is_some_and(|n| (1..=u16::from(MotorId::MAX)).contains(&n))
        };
        let code = data.first().copied();
        if per_motor(SINGLE_MOTOR_BASE_ID) || can_id == MULTI_TORQUE_CAN_ID {
            let replies: Vec<u16> = if can_id == MULTI_TORQUE_CAN_ID {
                (1..=u16::from(MotorId::MAX))
                    .map(|n| V3_REPLY_BASE_ID + n)
                    .collect()
            } else {
                vec![can_id - SINGLE_MOTOR_BASE_ID + V3_REPLY_BASE_ID]
            };
            for reply in replies {
                match code {
                    Some(code) => {
                        let waiting = self.pending.entry(reply).or_default();
                        if waiting.len() == V3_PENDING {
                            waiting.remove(0);
                        }
                        waiting.push(code);
                    }
                    None => {
                        self.pending.remove(&reply);
                    }
                }
            }
            Role::Request
        } else if per_motor(V3_REPLY_BASE_ID) {
            let waiting = self.pending.entry(can_id).or_default();
            let answered = match code.and_then(|c| waiting.iter().position(|&w| w == c)) {
                Some(at) => Some(waiting.remove(at)),
                // Paired with the last request, which it does not answer.
                None => waiting.pop(),
            };
            Role::Reply(answered.and_then(Command::from_code))
        } else if per_motor(V3_MOTION_REPLY_BASE_ID) {
            Role::Reply(None)
        } else {
            Role::Request
        }
    }
}

/// How many later lines a run of identical frames is held at most before it is decided without
/// its follower (as alternating reply, request, ...).
pub(crate) const HELD_LINES: usize = 256;

/// A handle on one frame's role, decided at once or later ([`LookAhead::take`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct Ticket(u64);

/// How a run of frames identical to the pending request is decided.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum RunIs {
    /// Followed by the reply: every frame is a request.
    Requests,
    /// Not followed by a reply: reply, request, reply, ...
    Alternating,
}

/// [`Pairing`] with look-ahead for runs of frames identical to a pending read request (see the
/// module docs). Frames go in with [`push`](Self::push); their roles come out with
/// [`take`](Self::take), in any order, once decided.
#[derive(Debug, Default)]
pub(crate) struct LookAhead {
    pairing: Pairing,
    next: u64,
    /// Decided roles not yet taken.
    roles: BTreeMap<Ticket, Role>,
    /// The undecided run of each CAN ID, oldest first.
    runs: HashMap<u16, Vec<Ticket>>,
}

impl LookAhead {
    /// Adds the next frame of the log; its role is decided now or when its run is.
    pub(crate) fn push(
        &mut self,
        can_id: u16,
        data: &[u8],
        marker: Option<FrameDirection>,
    ) -> Ticket {
        let ticket = Ticket(self.next);
        self.next += 1;
        if marker == Some(FrameDirection::Tx) {
            self.pairing.seen_tx = true;
        }
        let marker_decides = match marker {
            Some(FrameDirection::Tx) => true,
            Some(FrameDirection::Rx) => self.pairing.seen_tx,
            None => false,
        };
        let repeats = self
            .pairing
            .pending
            .get(&can_id)
            .is_some_and(|p| p.repeated_by(data));
        if can_id != MULTI_TORQUE_CAN_ID && !marker_decides && repeats {
            self.runs.entry(can_id).or_default().push(ticket);
            return ticket;
        }
        if can_id == MULTI_TORQUE_CAN_ID {
            for offset in 0..MULTI_TORQUE_MOTORS as u16 {
                self.resolve(FIRST_MOTOR_CAN_ID + offset, RunIs::Alternating);
            }
        } else if self.runs.contains_key(&can_id) {
            let is_reply = match marker {
                Some(FrameDirection::Tx) => false,
                Some(FrameDirection::Rx) if self.pairing.seen_tx => true,
                _ => {
                    let code = data.first().copied();
                    matches!(
                        (self.pairing.pending.get(&can_id), code),
                        (Some(p), Some(c)) if p.answered_by(c)
                    )
                }
            };
            let run = if is_reply {
                RunIs::Requests
            } else {
                RunIs::Alternating
            };
            self.resolve(can_id, run);
        }
        let role = self.pairing.classify(can_id, data, marker);
        self.roles.insert(ticket, role);
        ticket
    }

    /// The role of `ticket`, once decided (each role is given once).
    pub(crate) fn take(&mut self, ticket: Ticket) -> Option<Role> {
        self.roles.remove(&ticket)
    }

    /// Decides the run holding `ticket` without its follower (alternating): for a run held
    /// [`HELD_LINES`] lines.
    pub(crate) fn decide(&mut self, ticket: Ticket) {
        let id = self
            .runs
            .iter()
            .find(|(_, run)| run.contains(&ticket))
            .map(|(&id, _)| id);
        if let Some(id) = id {
            self.resolve(id, RunIs::Alternating);
        }
    }

    /// Decides every run (the end of the log: alternating).
    pub(crate) fn finish(&mut self) {
        let ids: Vec<u16> = self.runs.keys().copied().collect();
        for id in ids {
            self.resolve(id, RunIs::Alternating);
        }
    }

    /// Decides the run of `can_id`, if any, and updates the pending request.
    fn resolve(&mut self, can_id: u16, run_is: RunIs) {
        let Some(run) = self.runs.remove(&can_id) else {
            return;
        };
        let pending = self
            .pairing
            .pending
            .get(&can_id)
            .and_then(|p| Command::from_code(p.code));
        for (k, &ticket) in run.iter().enumerate() {
            let role = match run_is {
                RunIs::Requests => Role::Request,
                RunIs::Alternating if k % 2 == 0 => Role::Reply(pending),
                RunIs::Alternating => Role::Request,
            };
            self.roles.insert(ticket, role);
        }
        // The run repeats the pending request: it stays pending unless the run ends on a reply.
        if run_is == RunIs::Alternating && run.len() % 2 == 1 {
            self.pairing.pending.remove(&can_id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn v3_pairs_by_identifier_and_the_last_request() {
        let mut p = V3Pairing::default();
        assert_eq!(
            p.classify(0x141, &[0x9C, 0, 0, 0, 0, 0, 0, 0]),
            Role::Request
        );
        assert_eq!(
            p.classify(0x241, &[0x9C, 1, 2, 3, 4, 5, 6, 7]),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // Answered: the next frame on 0x241 pairs with nothing.
        assert_eq!(p.classify(0x241, &[0x9C; 8]), Role::Reply(None));
        // 0x280 leaves its command pending for every motor.
        assert_eq!(
            p.classify(0x280, &[0x80, 0, 0, 0, 0, 0, 0, 0]),
            Role::Request
        );
        assert_eq!(
            p.classify(0x243, &[0x80; 8]),
            Role::Reply(Some(Command::MotorOff))
        );
        assert_eq!(p.classify(0x401, &[0; 8]), Role::Request);
        assert_eq!(p.classify(0x501, &[1; 8]), Role::Reply(None));
    }

    #[test]
    fn v3_requests_sent_together_pair_with_their_own_replies() {
        let mut p = V3Pairing::default();
        // 0x9A and 0x9C at once, their replies in order: each pairs with its own.
        assert_eq!(
            p.classify(0x141, &[0x9A, 0, 0, 0, 0, 0, 0, 0]),
            Role::Request
        );
        assert_eq!(
            p.classify(0x141, &[0x9C, 0, 0, 0, 0, 0, 0, 0]),
            Role::Request
        );
        assert_eq!(
            p.classify(0x241, &[0x9A, 1, 2, 3, 4, 5, 6, 7]),
            Role::Reply(Some(Command::ReadStatus1))
        );
        assert_eq!(
            p.classify(0x241, &[0x9C, 1, 2, 3, 4, 5, 6, 7]),
            Role::Reply(Some(Command::ReadStatus2))
        );
        // A stale reply (another command than any pending) still pairs with the last request,
        // which decoding then reports as a mismatch.
        assert_eq!(
            p.classify(0x141, &[0x9A, 0, 0, 0, 0, 0, 0, 0]),
            Role::Request
        );
        assert_eq!(
            p.classify(0x241, &[0xB2, 0, 0, 0, 0x7A, 0x1E, 0xB4, 0x78]),
            Role::Reply(Some(Command::ReadStatus1))
        );
        // Many requests without replies: only the last few wait.
        for _ in 0..20 {
            p.classify(0x142, &[0x92, 0, 0, 0, 0, 0, 0, 0]);
        }
        assert_eq!(p.pending[&0x242].len(), V3_PENDING);
    }

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
        assert_eq!(
            p.classify(0x141, &A1, Some(FrameDirection::Tx)),
            Role::Request
        );
        assert_eq!(
            p.classify(0x141, &A1, Some(FrameDirection::Rx)),
            Role::Reply(Some(Command::Torque))
        );
        // A reply whose request was not logged: still a reply, with no pending command.
        assert_eq!(
            p.classify(0x141, &[0x9C], Some(FrameDirection::Rx)),
            Role::Reply(None)
        );
        // A lost reply: the next TX is a request even though the same command is pending.
        assert_eq!(
            p.classify(0x142, &A1, Some(FrameDirection::Tx)),
            Role::Request
        );
        assert_eq!(
            p.classify(0x142, &A1, Some(FrameDirection::Tx)),
            Role::Request
        );
    }

    #[test]
    fn listen_only_logs_fall_back_to_pairing() {
        let mut p = Pairing::default();
        assert_eq!(
            p.classify(0x141, &A1, Some(FrameDirection::Rx)),
            Role::Request
        );
        assert_eq!(
            p.classify(0x141, &A1, Some(FrameDirection::Rx)),
            Role::Reply(Some(Command::Torque))
        );
    }

    const Q9C: [u8; 8] = [0x9C, 0, 0, 0, 0, 0, 0, 0];
    const R9C: [u8; 8] = [0x9C, 30, 0, 0, 0, 0, 0, 0x10];

    #[test]
    fn classify_alone_takes_a_repeated_query_for_the_reply() {
        // Without look-ahead (`rmd replay`): the rules without the exception.
        let mut p = Pairing::default();
        assert_eq!(p.classify(0x141, &Q9C, None), Role::Request);
        assert_eq!(p.classify(0x141, &Q9C, None), STATUS2);
    }

    /// The roles of `frames` through the look-ahead, in order.
    fn marked(frames: &[(u16, &[u8], Option<FrameDirection>)]) -> Vec<Role> {
        let mut p = LookAhead::default();
        let tickets: Vec<Ticket> = frames.iter().map(|(id, d, m)| p.push(*id, d, *m)).collect();
        p.finish();
        tickets.into_iter().map(|t| p.take(t).unwrap()).collect()
    }

    #[test]
    fn a_query_with_other_reserved_bytes_is_not_a_repeat() {
        let mut other = Q9C;
        other[7] = 1;
        assert_eq!(
            looked_ahead(&[(0x141, &Q9C), (0x141, &other)]),
            [Role::Request, STATUS2]
        );
    }

    #[test]
    fn repeated_write_and_control_frames_are_replies() {
        // 0x80 and 0x31 replies echo their request byte for byte: identical is the reply.
        for frame in [
            [0x80, 0, 0, 0, 0, 0, 0, 0],
            [0x31, 0, 100, 100, 50, 40, 50, 50],
            A1,
        ] {
            let roles = looked_ahead(&[(0x143, &frame), (0x143, &frame)]);
            assert_eq!(roles[0], Role::Request);
            assert!(matches!(roles[1], Role::Reply(Some(_))), "{roles:?}");
        }
    }

    #[test]
    fn markers_win_over_the_repeat_rule() {
        let tx = Some(FrameDirection::Tx);
        let rx = Some(FrameDirection::Rx);
        assert_eq!(
            marked(&[
                (0x141, &Q9C, tx),
                // RX in a log with TX: the reply, even though identical to the request.
                (0x141, &Q9C, rx),
                // TX: a request, even though it answers the pending command.
                (0x141, &Q9C, tx),
                (0x141, &R9C, tx),
            ]),
            [Role::Request, STATUS2, Role::Request, Role::Request]
        );
        // A listen-only log (RX only): the look-ahead decides.
        assert_eq!(
            marked(&[(0x141, &Q9C, rx), (0x141, &Q9C, rx), (0x141, &R9C, rx)]),
            [Role::Request, Role::Request, STATUS2]
        );
    }

    /// The roles of `frames` (unmarked) through the look-ahead, in order.
    fn looked_ahead(frames: &[(u16, &[u8])]) -> Vec<Role> {
        let with: Vec<(u16, &[u8], Option<FrameDirection>)> =
            frames.iter().map(|&(id, d)| (id, d, None)).collect();
        marked(&with)
    }

    const Q9D: [u8; 8] = [0x9D, 0, 0, 0, 0, 0, 0, 0];
    const Q9A: [u8; 8] = [0x9A, 0, 0, 0, 0, 0, 0, 0];
    const STATUS2: Role = Role::Reply(Some(Command::ReadStatus2));
    const STATUS3: Role = Role::Reply(Some(Command::ReadStatus3));

    #[test]
    fn look_ahead_query_query_reply() {
        assert_eq!(
            looked_ahead(&[(0x141, &Q9C), (0x141, &Q9C), (0x142, &Q9C), (0x141, &R9C)]),
            [Role::Request, Role::Request, Role::Request, STATUS2]
        );
    }

    #[test]
    fn look_ahead_zero_replies_of_a_motor_at_rest() {
        // Status reads of a motor at rest: 0x9D's reply is all zeros, then the next read.
        assert_eq!(
            looked_ahead(&[(0x141, &Q9D), (0x141, &Q9D), (0x141, &Q9A)]),
            [Role::Request, STATUS3, Role::Request]
        );
        // Repeated at the end of the log: request, reply, request, reply.
        assert_eq!(
            looked_ahead(&[(0x141, &Q9D), (0x141, &Q9D), (0x141, &Q9D), (0x141, &Q9D)]),
            [Role::Request, STATUS3, Role::Request, STATUS3]
        );
        // After an odd run, nothing is pending: the next 0x9D is a request.
        assert_eq!(
            looked_ahead(&[(0x141, &Q9D), (0x141, &Q9D), (0x141, &Q9A), (0x141, &Q9D)]),
            [Role::Request, STATUS3, Role::Request, Role::Request]
        );
    }

    #[test]
    fn look_ahead_the_ambiguity_left() {
        // Query, zero reply, query, reply with data: read as three requests and a reply.
        let r9d = [0x9D, 0, 0x40, 0, 0, 0, 0, 0];
        assert_eq!(
            looked_ahead(&[(0x141, &Q9D), (0x141, &Q9D), (0x141, &Q9D), (0x141, &r9d)]),
            [Role::Request, Role::Request, Role::Request, STATUS3]
        );
    }

    #[test]
    fn look_ahead_holds_roles_until_decided_and_markers_decide_at_once() {
        let mut p = LookAhead::default();
        let q = p.push(0x141, &Q9D, None);
        let z = p.push(0x141, &Q9D, None);
        let other = p.push(0x142, &Q9C, None);
        assert_eq!(p.take(q), Some(Role::Request));
        assert_eq!(p.take(z), None);
        assert_eq!(p.take(other), Some(Role::Request));
        p.decide(z);
        assert_eq!(p.take(z), Some(STATUS3));
        // TX / RX in a log with TX: no run is held.
        let mut p = LookAhead::default();
        let q = p.push(0x141, &Q9C, Some(FrameDirection::Tx));
        let r = p.push(0x141, &Q9C, Some(FrameDirection::Rx));
        assert_eq!((p.take(q), p.take(r)), (Some(Role::Request), Some(STATUS2)));
    }
}
