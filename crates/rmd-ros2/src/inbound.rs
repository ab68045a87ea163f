//! Decoding the node's input topics within [`InputLimits`]: every string and array of an
//! inbound message is measured while it is decoded, before anything of it is copied, and a
//! message over a limit decodes as an [`Oversize`] (what was too large, by how much, and a
//! short excerpt) instead of the message. Decoding stops there; nothing more of it is read.
//!
//! The layout is CDR's: a struct is its fields in order, a sequence its length then its
//! elements, so each message is decoded as a fixed-length tuple of its fields (what serde's
//! derive does for these types), with bounded seeds in place of `String` and `Vec`.

use std::fmt;
use std::marker::PhantomData;

use serde::Deserialize;
use serde::de::{self, DeserializeSeed, Deserializer, SeqAccess, Visitor};

use crate::config::InputLimits;
use crate::msg;

/// Bytes of an oversized string kept for the rejection's text.
const EXCERPT_BYTES: usize = 32;

/// An inbound message over one of the [`InputLimits`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Oversize {
    /// A string longer than `max_string_bytes`.
    #[error(
        "{what} of {bytes} bytes is longer than the node's limit of {limit} bytes (it begins {excerpt:?})"
    )]
    String {
        /// Which field.
        what: &'static str,
        /// Its length on the wire.
        bytes: usize,
        /// The limit.
        limit: usize,
        /// Its first bytes (at most 32, cut at a character boundary).
        excerpt: String,
    },
    /// An array with more elements than the limit for it.
    #[error("{what} has more than the node's limit of {limit} elements")]
    Array {
        /// Which field.
        what: &'static str,
        /// The limit.
        limit: usize,
    },
}

/// What a message or field decodes to: it, or why it is too large.
type Decoded<M> = Result<M, Oversize>;

/// An input topic's sample, decoded within the limits: the message, or why it is too large.
/// (Its `Deserialize` applies the default [`InputLimits`]; the node decodes with its own
/// through [`InboundSeed`].)
pub(crate) struct Inbound<M>(pub(crate) Decoded<M>);

impl<'de, M> Deserialize<'de> for Inbound<M>
where
    for<'a> Bounded<'a, M>: DeserializeSeed<'de, Value = Decoded<M>>,
{
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let limits = InputLimits::default();
        Bounded::<M>::new(&limits, "message")
            .deserialize(d)
            .map(Inbound)
    }
}

/// Decodes an [`Inbound`] sample within `limits`.
pub(crate) struct InboundSeed<'a, M>(Bounded<'a, M>);

impl<'a, M> InboundSeed<'a, M> {
    /// `topic` names the message in rejections.
    pub(crate) fn new(limits: &'a InputLimits, topic: &'static str) -> Self {
        InboundSeed(Bounded::new(limits, topic))
    }
}

impl<M> Clone for InboundSeed<'_, M> {
    fn clone(&self) -> Self {
        InboundSeed(self.0)
    }
}

impl<'de, 'a, M> DeserializeSeed<'de> for InboundSeed<'a, M>
where
    Bounded<'a, M>: DeserializeSeed<'de, Value = Decoded<M>>,
{
    type Value = Inbound<M>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        self.0.deserialize(d).map(Inbound)
    }
}

/// The first bytes of `s`, cut at a character boundary.
pub(crate) fn excerpt(s: &str, max: usize) -> &str {
    let mut end = max.min(s.len());
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
}

/// A seed that decodes a `T` within the limits, as an [`Decoded<T>`].
pub(crate) struct Bounded<'a, T> {
    limits: &'a InputLimits,
    what: &'static str,
    _t: PhantomData<fn() -> T>,
}

// Copy whatever `T` is: only a reference and a name are inside.
impl<T> Clone for Bounded<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Bounded<'_, T> {}

impl<'a, T> Bounded<'a, T> {
    pub(crate) fn new(limits: &'a InputLimits, what: &'static str) -> Self {
        Bounded {
            limits,
            what,
            _t: PhantomData,
        }
    }

    fn field<U>(&self, what: &'static str) -> Bounded<'a, U> {
        Bounded::new(self.limits, what)
    }
}

/// The next field of a struct decoded as a tuple; a missing one is a decoding error.
fn field<'de, A, S>(
    seq: &mut A,
    seed: S,
    index: usize,
    of: &'static str,
) -> Result<S::Value, A::Error>
where
    A: SeqAccess<'de>,
    S: DeserializeSeed<'de>,
{
    seq.next_element_seed(seed)?
        .ok_or_else(|| de::Error::invalid_length(index, &of))
}

/// Decodes a struct of `n` fields with `visit`.
fn tuple<'de, D, V>(d: D, n: usize, visit: V) -> Result<V::Value, D::Error>
where
    D: Deserializer<'de>,
    V: Visitor<'de>,
{
    d.deserialize_tuple(n, visit)
}

// ---- strings

impl<'de> DeserializeSeed<'de> for Bounded<'_, String> {
    type Value = Decoded<String>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_str(self)
    }
}

impl<'de> Visitor<'de> for Bounded<'_, String> {
    type Value = Decoded<String>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (a string)", self.what)
    }
    // The string is still in the sample's buffer here: it is measured before it is copied.
    fn visit_str<E: de::Error>(self, s: &str) -> Result<Self::Value, E> {
        let limit = self.limits.max_string_bytes;
        if s.len() > limit {
            return Ok(Err(Oversize::String {
                what: self.what,
                bytes: s.len(),
                limit,
                excerpt: excerpt(s, EXCERPT_BYTES).to_owned(),
            }));
        }
        Ok(Ok(s.to_owned()))
    }
}

// ---- sequences

/// A sequence of at most `max` elements, each decoded by `element`.
struct BoundedSeq<S> {
    element: S,
    max: usize,
    what: &'static str,
}

impl<'de, T, S> DeserializeSeed<'de> for BoundedSeq<S>
where
    S: DeserializeSeed<'de, Value = Decoded<T>> + Copy,
{
    type Value = Decoded<Vec<T>>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de, T, S> Visitor<'de> for BoundedSeq<S>
where
    S: DeserializeSeed<'de, Value = Decoded<T>> + Copy,
{
    type Value = Decoded<Vec<T>>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (a sequence)", self.what)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        // Grows as elements arrive (no allocation from the length on the wire), up to `max`.
        let mut out = Vec::new();
        while let Some(element) = seq.next_element_seed(self.element)? {
            if out.len() == self.max {
                return Ok(Err(Oversize::Array {
                    what: self.what,
                    limit: self.max,
                }));
            }
            match element {
                Ok(e) => out.push(e),
                Err(o) => return Ok(Err(o)),
            }
        }
        Ok(Ok(out))
    }
}

/// A value with nothing to bound (numbers, times), as an [`Inbound`].
struct Plain<T>(PhantomData<fn() -> T>);

impl<T> Clone for Plain<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Plain<T> {}

impl<'de, T: Deserialize<'de>> DeserializeSeed<'de> for Plain<T> {
    type Value = Decoded<T>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        T::deserialize(d).map(Ok)
    }
}

impl<'a, T> Bounded<'a, T> {
    fn strings(&self, what: &'static str) -> BoundedSeq<Bounded<'a, String>> {
        BoundedSeq {
            element: self.field(what),
            max: self.limits.max_array_len,
            what,
        }
    }

    fn numbers(&self, what: &'static str) -> BoundedSeq<Plain<f64>> {
        BoundedSeq {
            element: Plain(PhantomData),
            max: self.limits.max_array_len,
            what,
        }
    }
}

/// Takes a field's value, or returns the oversize from the visitor.
macro_rules! take {
    ($e:expr) => {
        match $e {
            Ok(v) => v,
            Err(o) => return Ok(Err(o)),
        }
    };
}

// ---- messages

impl<'de> DeserializeSeed<'de> for Bounded<'_, msg::Header> {
    type Value = Decoded<msg::Header>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        tuple(d, 2, self)
    }
}

impl<'de> Visitor<'de> for Bounded<'_, msg::Header> {
    type Value = Decoded<msg::Header>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("std_msgs/Header")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let stamp = take!(field(
            &mut seq,
            Plain::<msg::Time>(PhantomData),
            0,
            "Header"
        )?);
        let frame_id = take!(field(
            &mut seq,
            self.field::<String>("frame_id"),
            1,
            "Header"
        )?);
        Ok(Ok(msg::Header { stamp, frame_id }))
    }
}

impl<'de> DeserializeSeed<'de> for Bounded<'_, msg::JointState> {
    type Value = Decoded<msg::JointState>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        tuple(d, 5, self)
    }
}

impl<'de> Visitor<'de> for Bounded<'_, msg::JointState> {
    type Value = Decoded<msg::JointState>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("sensor_msgs/JointState")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        const OF: &str = "JointState";
        let header = take!(field(&mut seq, self.field::<msg::Header>("header"), 0, OF)?);
        let name = take!(field(&mut seq, self.strings("name"), 1, OF)?);
        let position = take!(field(&mut seq, self.numbers("position"), 2, OF)?);
        let velocity = take!(field(&mut seq, self.numbers("velocity"), 3, OF)?);
        let effort = take!(field(&mut seq, self.numbers("effort"), 4, OF)?);
        Ok(Ok(msg::JointState {
            header,
            name,
            position,
            velocity,
            effort,
        }))
    }
}

impl<'de> DeserializeSeed<'de> for Bounded<'_, msg::JointTrajectoryPoint> {
    type Value = Decoded<msg::JointTrajectoryPoint>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        tuple(d, 5, self)
    }
}

impl<'de> Visitor<'de> for Bounded<'_, msg::JointTrajectoryPoint> {
    type Value = Decoded<msg::JointTrajectoryPoint>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("trajectory_msgs/JointTrajectoryPoint")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        const OF: &str = "JointTrajectoryPoint";
        let positions = take!(field(&mut seq, self.numbers("positions"), 0, OF)?);
        let velocities = take!(field(&mut seq, self.numbers("velocities"), 1, OF)?);
        let accelerations = take!(field(&mut seq, self.numbers("accelerations"), 2, OF)?);
        let effort = take!(field(&mut seq, self.numbers("effort"), 3, OF)?);
        let time_from_start = take!(field(&mut seq, Plain::<msg::Duration>(PhantomData), 4, OF)?);
        Ok(Ok(msg::JointTrajectoryPoint {
            positions,
            velocities,
            accelerations,
            effort,
            time_from_start,
        }))
    }
}

impl<'de> DeserializeSeed<'de> for Bounded<'_, msg::JointTrajectory> {
    type Value = Decoded<msg::JointTrajectory>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        tuple(d, 3, self)
    }
}

impl<'de> Visitor<'de> for Bounded<'_, msg::JointTrajectory> {
    type Value = Decoded<msg::JointTrajectory>;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("trajectory_msgs/JointTrajectory")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        const OF: &str = "JointTrajectory";
        let header = take!(field(&mut seq, self.field::<msg::Header>("header"), 0, OF)?);
        let joint_names = take!(field(&mut seq, self.strings("joint_names"), 1, OF)?);
        let points = BoundedSeq {
            element: self.field::<msg::JointTrajectoryPoint>("points"),
            max: self.limits.max_points,
            what: "points",
        };
        let points = take!(field(&mut seq, points, 2, OF)?);
        Ok(Ok(msg::JointTrajectory {
            header,
            joint_names,
            points,
        }))
    }
}

impl<'de> DeserializeSeed<'de> for Bounded<'_, msg::Bool> {
    type Value = Decoded<msg::Bool>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        msg::Bool::deserialize(d).map(Ok)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> InputLimits {
        InputLimits {
            max_string_bytes: 16,
            max_array_len: 4,
            max_points: 3,
            ..InputLimits::default()
        }
    }

    /// Plain CDR, little endian, by an encoder independent of the node's decoder, without
    /// the 4-byte encapsulation header (DDS strips it before decoding).
    fn cdr<T: serde::Serialize>(m: &T) -> Vec<u8> {
        cdr::serialize::<_, _, cdr::CdrLe>(m, cdr::Infinite).unwrap()[4..].to_vec()
    }

    fn decode<'a, M>(bytes: &'a [u8], limits: &'a InputLimits) -> Decoded<M>
    where
        Bounded<'a, M>: DeserializeSeed<'a, Value = Decoded<M>>,
    {
        let mut d = cdr_encoding::CdrDeserializer::<byteorder::LittleEndian>::new(bytes);
        Bounded::<M>::new(limits, "message")
            .deserialize(&mut d)
            .unwrap()
    }

    fn state(names: &[&str], n: usize) -> msg::JointState {
        msg::JointState {
            header: msg::Header {
                stamp: msg::Time { sec: 5, nanosec: 7 },
                frame_id: "base".into(),
            },
            name: names.iter().map(|s| s.to_string()).collect(),
            position: vec![0.5; n],
            velocity: vec![],
            effort: vec![1.5; n],
        }
    }

    #[test]
    fn messages_within_the_limits_decode_as_serde_would() {
        let l = limits();
        let m = state(&["hip", "knee"], 2);
        assert_eq!(decode::<msg::JointState>(&cdr(&m), &l), Ok(m));
        let t = msg::JointTrajectory {
            header: msg::Header::default(),
            joint_names: vec!["knee".into()],
            points: vec![
                msg::JointTrajectoryPoint {
                    positions: vec![0.1],
                    velocities: vec![0.0],
                    accelerations: vec![],
                    effort: vec![],
                    time_from_start: msg::Duration {
                        sec: 1,
                        nanosec: 500,
                    },
                };
                3
            ],
        };
        assert_eq!(decode::<msg::JointTrajectory>(&cdr(&t), &l), Ok(t));
        let b = msg::Bool { data: true };
        assert_eq!(decode::<msg::Bool>(&cdr(&b), &l), Ok(b));
    }

    #[test]
    fn a_long_string_is_refused_with_a_short_excerpt() {
        let l = limits();
        let long = "x".repeat(100_000);
        let got = decode::<msg::JointState>(&cdr(&state(&["hip", &long], 2)), &l);
        let Err(Oversize::String {
            what,
            bytes,
            limit,
            excerpt,
        }) = got
        else {
            panic!("{got:?}");
        };
        assert_eq!((what, bytes, limit), ("name", 100_000, 16));
        assert_eq!(excerpt, "x".repeat(32));
        let text = Oversize::String {
            what,
            bytes,
            limit,
            excerpt,
        }
        .to_string();
        assert!(text.len() < 200, "{text}");
        // The frame id too, and a multi-byte character is never cut in half.
        let mut m = state(&["hip"], 1);
        m.header.frame_id = "é".repeat(40);
        let Err(Oversize::String { what, excerpt, .. }) = decode::<msg::JointState>(&cdr(&m), &l)
        else {
            panic!()
        };
        assert_eq!(
            (what, excerpt.as_str()),
            ("frame_id", "é".repeat(16).as_str())
        );
    }

    #[test]
    fn long_arrays_and_too_many_points_are_refused() {
        let l = limits();
        assert_eq!(
            decode::<msg::JointState>(&cdr(&state(&["a"; 5], 1)), &l),
            Err(Oversize::Array {
                what: "name",
                limit: 4
            })
        );
        assert_eq!(
            decode::<msg::JointState>(&cdr(&state(&["a"], 5)), &l),
            Err(Oversize::Array {
                what: "position",
                limit: 4
            })
        );
        let t = msg::JointTrajectory {
            points: vec![msg::JointTrajectoryPoint::default(); 4],
            ..msg::JointTrajectory::default()
        };
        assert_eq!(
            decode::<msg::JointTrajectory>(&cdr(&t), &l),
            Err(Oversize::Array {
                what: "points",
                limit: 3
            })
        );
        let t = msg::JointTrajectory {
            points: vec![msg::JointTrajectoryPoint {
                velocities: vec![0.0; 9],
                ..msg::JointTrajectoryPoint::default()
            }],
            ..msg::JointTrajectory::default()
        };
        assert_eq!(
            decode::<msg::JointTrajectory>(&cdr(&t), &l),
            Err(Oversize::Array {
                what: "velocities",
                limit: 4
            })
        );
    }

    #[test]
    fn a_length_beyond_the_sample_is_a_decoding_error_not_an_allocation() {
        let l = limits();
        // name: a sequence claiming 2^32 - 1 strings, then nothing.
        let mut bytes = cdr(&msg::Header::default());
        while bytes.len() % 4 != 0 {
            bytes.push(0);
        }
        bytes.extend_from_slice(&u32::MAX.to_le_bytes());
        let mut d = cdr_encoding::CdrDeserializer::<byteorder::LittleEndian>::new(&bytes);
        assert!(
            Bounded::<msg::JointState>::new(&l, "message")
                .deserialize(&mut d)
                .is_err()
        );
    }
}
