//! How long a CAN frame occupies the wire: exact bit-stuffed lengths (from the frame's content,
//! CRC-15 included), worst cases, and the time budget of one 0x280 exchange.
//!
//! A classic CAN data frame with a standard identifier is, on the wire:
//!
//! | field | bits | stuffed |
//! |---|---|---|
//! | SOF, identifier, RTR, IDE, r0, DLC | 1 + 11 + 1 + 1 + 1 + 4 | yes |
//! | data | 8 x DLC | yes |
//! | CRC sequence | 15 | yes |
//! | CRC delimiter, ACK slot, ACK delimiter, end of frame | 1 + 1 + 1 + 7 | no |
//! | intermission (interframe space) | 3 | no |
//!
//! Bit stuffing inserts a complementary bit after every run of five equal bits in the stuffed
//! part (the inserted bit counts towards the next run), so the length depends on the content: an
//! 8-byte frame takes 111 to 135 bit times including the interframe space.

use core::time::Duration;

use rmd_protocol::CanFrame;

/// Bits of the stuffed part before the data: SOF, 11-bit ID, RTR, IDE, r0 and the 4-bit DLC.
const HEADER_BITS: u32 = 19;
/// CRC-15 sequence.
const CRC_BITS: u32 = 15;
/// CRC delimiter, ACK slot, ACK delimiter and 7-bit end of frame: never stuffed.
const TRAILER_BITS: u32 = 10;
/// Intermission between two frames.
pub const INTERFRAME_BITS: u32 = 3;

/// The CAN CRC-15 polynomial x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1.
const CRC15_POLY: u16 = 0x4599;

/// A fixed-size bit sequence (at most 19 + 64 + 15 = 98 bits for a classic frame).
struct Bits {
    bits: [bool; 98],
    len: usize,
}

impl Bits {
    fn push(&mut self, value: u32, width: u32) {
        for i in (0..width).rev() {
            self.bits[self.len] = (value >> i) & 1 == 1;
            self.len += 1;
        }
    }
}

/// The unstuffed bit sequence from SOF to the end of the CRC.
fn stuffed_region(frame: &CanFrame) -> Bits {
    let mut out = Bits {
        bits: [false; 98],
        len: 0,
    };
    out.push(0, 1); // SOF (dominant)
    out.push(u32::from(frame.id()), 11);
    out.push(0, 1); // RTR: data frame
    out.push(0, 1); // IDE: standard identifier
    out.push(0, 1); // r0
    out.push(u32::from(frame.dlc()), 4);
    for &byte in frame.data() {
        out.push(u32::from(byte), 8);
    }
    let mut crc: u16 = 0;
    for &bit in &out.bits[..out.len] {
        let next = bit ^ ((crc >> 14) & 1 == 1);
        crc = (crc << 1) & 0x7FFF;
        if next {
            crc ^= CRC15_POLY;
        }
    }
    out.push(u32::from(crc), CRC_BITS);
    out
}

/// Number of stuff bits the transmitter inserts into `frame`.
///
/// ```
/// use rmd_bus::wire::stuff_bits;
/// use rmd_protocol::CanFrame;
/// // Eight 0x00 bytes make long runs of dominant bits: many stuff bits.
/// let zeros = CanFrame::with_data(0x141, [0; 8]).unwrap();
/// let mixed = CanFrame::with_data(0x141, [0x55; 8]).unwrap();
/// assert!(stuff_bits(&zeros) > stuff_bits(&mixed));
/// ```
pub fn stuff_bits(frame: &CanFrame) -> u32 {
    let region = stuffed_region(frame);
    count_stuff_bits(&region.bits[..region.len])
}

/// Stuff bits a transmitter inserts into `bits`.
fn count_stuff_bits(bits: &[bool]) -> u32 {
    let mut stuffed = 0;
    let mut run = 0;
    let mut last = None;
    for &bit in bits {
        if Some(bit) == last {
            run += 1;
        } else {
            last = Some(bit);
            run = 1;
        }
        if run == 5 {
            // The stuff bit is the complement and starts a new run of length 1.
            stuffed += 1;
            last = Some(!bit);
            run = 1;
        }
    }
    stuffed
}

/// Bit times `frame` occupies on the wire, stuff bits and the 3-bit interframe space included.
///
/// ```
/// use rmd_bus::wire::frame_bits;
/// use rmd_protocol::CanFrame;
/// let frame = CanFrame::with_data(0x280, [0x64, 0, 0x64, 0, 0x64, 0, 0x64, 0]).unwrap();
/// let bits = frame_bits(&frame);
/// assert!((111..=135).contains(&bits));
/// ```
pub fn frame_bits(frame: &CanFrame) -> u32 {
    HEADER_BITS
        + 8 * u32::from(frame.dlc())
        + CRC_BITS
        + stuff_bits(frame)
        + TRAILER_BITS
        + INTERFRAME_BITS
}

/// The most bit times any standard data frame with `dlc` data bytes can take (worst-case
/// stuffing), interframe space included: 135 for DLC 8.
pub const fn worst_case_frame_bits(dlc: u8) -> u32 {
    let stuffed = HEADER_BITS + 8 * dlc as u32 + CRC_BITS;
    stuffed + (stuffed - 1) / 4 + TRAILER_BITS + INTERFRAME_BITS
}

/// Converts bit times to time at `bitrate` bit/s (rounded up to the nanosecond).
///
/// A zero bitrate yields [`Duration::MAX`]: nothing can be sent.
pub const fn bits_to_duration(bits: u32, bitrate: u32) -> Duration {
    if bitrate == 0 {
        return Duration::MAX;
    }
    let nanos = (bits as u64 * 1_000_000_000).div_ceil(bitrate as u64);
    Duration::from_nanos(nanos)
}

/// Time `frame` occupies the wire at `bitrate` bit/s.
pub fn frame_duration(frame: &CanFrame, bitrate: u32) -> Duration {
    bits_to_duration(frame_bits(frame), bitrate)
}

/// Worst-case duration of one multi-motor torque exchange on one bus: the 0x280 frame, the
/// motors' turnaround, then the `motors` replies back to back, every frame with worst-case
/// stuffing. Buses run in parallel, so a robot's exchange takes the longest of its buses.
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::wire::exchange_budget;
/// // 5 frames of at most 135 bits at 1 Mbit/s, plus 200 us turnaround: 875 us.
/// let t = exchange_budget(4, 1_000_000, Duration::from_micros(200));
/// assert_eq!(t, Duration::from_micros(875));
/// ```
pub const fn exchange_budget(motors: u32, bitrate: u32, turnaround: Duration) -> Duration {
    exchange_budget_of(1, motors, bitrate, turnaround)
}

/// Worst-case duration of one exchange of `requests` request frames and `replies` replies on
/// one bus, every frame 8 bytes with worst-case stuffing: the requests go out back to back;
/// the first motor answers `turnaround` after the first request, and the replies follow each
/// other. So the replies start when the last request is through or when the first motor's
/// turnaround ends, whichever is later: `max(requests * F, F + turnaround) + replies * F`.
/// With one request (a 0x280 frame) that is [`exchange_budget`].
///
/// ```
/// use core::time::Duration;
/// use rmd_bus::wire::exchange_budget_of;
/// let t = Duration::from_micros(200);
/// // Three per-motor requests (405 us) outlast the first motor's turnaround (335 us): 810 us.
/// assert_eq!(exchange_budget_of(3, 3, 1_000_000, t), Duration::from_micros(810));
/// // One request: 135 + 200 + 3 * 135 = 740 us.
/// assert_eq!(exchange_budget_of(1, 3, 1_000_000, t), Duration::from_micros(740));
/// ```
pub const fn exchange_budget_of(
    requests: u32,
    replies: u32,
    bitrate: u32,
    turnaround: Duration,
) -> Duration {
    let frame = bits_to_duration(worst_case_frame_bits(8), bitrate);
    let requests_done = bits_to_duration(worst_case_frame_bits(8) * requests, bitrate);
    let first_ready = frame.saturating_add(turnaround);
    let start = if requests_done.as_nanos() > first_ready.as_nanos() {
        requests_done
    } else {
        first_ready
    };
    start.saturating_add(bits_to_duration(
        worst_case_frame_bits(8) * replies,
        bitrate,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u16, data: [u8; 8]) -> CanFrame {
        CanFrame::with_data(id, data).unwrap()
    }

    #[test]
    fn crc15_matches_the_can_specification_check_value() {
        // The CRC-15/CAN check value over the ASCII bytes "123456789" is 0x059E.
        let mut crc: u16 = 0;
        for byte in b"123456789" {
            for i in (0..8).rev() {
                let bit = (byte >> i) & 1 == 1;
                let next = bit ^ ((crc >> 14) & 1 == 1);
                crc = (crc << 1) & 0x7FFF;
                if next {
                    crc ^= CRC15_POLY;
                }
            }
        }
        assert_eq!(crc, 0x059E);
    }

    #[test]
    fn stuffing_counts_runs_of_five_including_stuff_bits() {
        // ID 0x000 with DLC 0: SOF + 11 zero ID bits + RTR/IDE/r0 zero + DLC 0000 = 19 dominant
        // bits, then the CRC of that (zero) = 15 more zero bits: 34 zeros in a row. Each stuff
        // bit is recessive and the next zero starts a new run, so a stuff bit follows zeros 5,
        // 10, 15, 20, 25 and 30: 6 stuff bits.
        let f = CanFrame::new(0x000, &[]).unwrap();
        assert_eq!(stuff_bits(&f), 6);
        assert_eq!(frame_bits(&f), 19 + 15 + 6 + 10 + 3);

        // A stuff bit counts towards the next run: after 00000 comes a stuff 1, which with the
        // four 1s that follow makes a run of five: a second stuff bit.
        let (o, l) = (false, true);
        assert_eq!(count_stuff_bits(&[o, o, o, o, o, l, l, l, l]), 2);
        assert_eq!(count_stuff_bits(&[o, o, o, o, o, l, l, l]), 1);
        assert_eq!(count_stuff_bits(&[o, o, o, o, l, l, l, l]), 0);

        // Field layout: SOF then the identifier MSB first.
        let g = CanFrame::new(0x7C0, &[]).unwrap();
        let region = stuffed_region(&g);
        assert_eq!(&region.bits[..12], &[o, l, l, l, l, l, o, o, o, o, o, o]);
    }

    #[test]
    fn a_frame_never_exceeds_the_worst_case() {
        let mut seed: u32 = 0x1234_5678;
        for _ in 0..2_000 {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            let id = (seed & 0x7FF) as u16;
            let data = seed.to_le_bytes();
            let f = frame(
                id,
                [data[0], data[1], data[2], data[3], 0, 0, 0xFF, data[0]],
            );
            assert!(frame_bits(&f) <= worst_case_frame_bits(8));
            assert!(frame_bits(&f) >= HEADER_BITS + 64 + CRC_BITS + TRAILER_BITS + INTERFRAME_BITS);
        }
        assert_eq!(worst_case_frame_bits(8), 135);
        assert_eq!(worst_case_frame_bits(0), 19 + 15 + 8 + 10 + 3);
    }

    #[test]
    fn durations_follow_the_bitrate() {
        assert_eq!(
            bits_to_duration(135, 1_000_000),
            Duration::from_nanos(135_000)
        );
        assert_eq!(
            bits_to_duration(135, 500_000),
            Duration::from_nanos(270_000)
        );
        assert_eq!(bits_to_duration(1, 3), Duration::from_nanos(333_333_334));
        assert_eq!(bits_to_duration(1, 0), Duration::MAX);
    }
}
