//! Little-endian field access on the 8 data bytes. Offsets are const generics, so an offset
//! beyond the frame is a compile error, never a run-time panic.

pub(crate) const fn u16_at<const AT: usize>(d: &[u8; 8]) -> u16 {
    u16::from_le_bytes([d[AT], d[AT + 1]])
}

pub(crate) const fn i16_at<const AT: usize>(d: &[u8; 8]) -> i16 {
    i16::from_le_bytes([d[AT], d[AT + 1]])
}

pub(crate) const fn i32_at<const AT: usize>(d: &[u8; 8]) -> i32 {
    i32::from_le_bytes([d[AT], d[AT + 1], d[AT + 2], d[AT + 3]])
}

pub(crate) const fn u32_at<const AT: usize>(d: &[u8; 8]) -> u32 {
    u32::from_le_bytes([d[AT], d[AT + 1], d[AT + 2], d[AT + 3]])
}

pub(crate) const fn put_u32<const AT: usize>(d: &mut [u8; 8], v: u32) {
    let b = v.to_le_bytes();
    d[AT] = b[0];
    d[AT + 1] = b[1];
    d[AT + 2] = b[2];
    d[AT + 3] = b[3];
}

pub(crate) const fn put_u16<const AT: usize>(d: &mut [u8; 8], v: u16) {
    let b = v.to_le_bytes();
    d[AT] = b[0];
    d[AT + 1] = b[1];
}

pub(crate) const fn put_i16<const AT: usize>(d: &mut [u8; 8], v: i16) {
    put_u16::<AT>(d, v as u16);
}

pub(crate) const fn put_i32<const AT: usize>(d: &mut [u8; 8], v: i32) {
    let b = v.to_le_bytes();
    d[AT] = b[0];
    d[AT + 1] = b[1];
    d[AT + 2] = b[2];
    d[AT + 3] = b[3];
}

/// The 56-bit two's-complement value in DATA\[1..=7\], sign-extended (the 0x92 reply).
pub(crate) const fn i56_at_1(d: &[u8; 8]) -> i64 {
    // Put the 7 bytes in the top of an i64, then shift back arithmetically to sign-extend.
    let v = i64::from_le_bytes([0, d[1], d[2], d[3], d[4], d[5], d[6], d[7]]);
    v >> 8
}

/// Writes the low 56 bits of `v` to DATA\[1..=7\].
pub(crate) const fn put_i56_at_1(d: &mut [u8; 8], v: i64) {
    let b = v.to_le_bytes();
    d[1] = b[0];
    d[2] = b[1];
    d[3] = b[2];
    d[4] = b[3];
    d[5] = b[4];
    d[6] = b[5];
    d[7] = b[6];
}
