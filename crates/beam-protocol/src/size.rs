//! Worst-case encoded sizes: [`MaxSize`], the longest postcard encoding of
//! a type, implemented for the primitives, `Option` and `heapless::Vec`
//! here and for each message next to its struct (`command`, `telemetry`);
//! `budget` sums them into frame sizes and link loads.
//!
//! (postcard's own `MaxSize`, behind its `experimental-derive` feature,
//! covers only the `heapless` 0.7 `Vec`, not the 0.9 one these messages
//! hold, and the orphan rule keeps this crate from adding that impl; hence
//! this crate's trait, with the same meaning.)

/// The longest postcard encoding of a value of the type, in bytes. Each
/// message type implements it next to its definition, as the sum of its
/// fields' sizes (an enum: its tag and its longest variant).
pub trait MaxSize {
    /// Longest encoding (bytes).
    const MAX_SIZE: usize;
}

/// Bytes of the postcard varint of `n` (7 bits per byte).
pub(crate) const fn varint_len(n: usize) -> usize {
    let mut len = 1;
    let mut rest = n >> 7;
    while rest > 0 {
        len += 1;
        rest >>= 7;
    }
    len
}

/// Longest postcard enum tag of a type with `variants` variants: the
/// varint of the last index.
pub(crate) const fn tag_len(variants: usize) -> usize {
    varint_len(variants.saturating_sub(1))
}

/// The larger of two sizes (for an enum's longest variant).
pub(crate) const fn max(a: usize, b: usize) -> usize {
    if a > b {
        a
    } else {
        b
    }
}

/// The number of fields of a struct `S` whose fields are all of type `F`
/// (one alignment, so no padding): its size over the field's.
pub(crate) const fn fields_of<S, F>() -> usize {
    core::mem::size_of::<S>() / core::mem::size_of::<F>()
}

macro_rules! max_size {
    ($($t:ty => $n:expr),* $(,)?) => {$(
        impl MaxSize for $t {
            const MAX_SIZE: usize = $n;
        }
    )*};
}
// postcard: u8 and bool as one byte, f32 as four, wider integers as
// varints of ⌈bits/7⌉ bytes at most.
max_size!(u8 => 1, bool => 1, f32 => 4, u16 => 3, u32 => 5, u64 => 10);

impl<T: MaxSize> MaxSize for Option<T> {
    /// Tag byte and value.
    const MAX_SIZE: usize = 1 + T::MAX_SIZE;
}

impl<T: MaxSize, const N: usize> MaxSize for heapless::Vec<T, N> {
    /// Length varint and N elements.
    const MAX_SIZE: usize = varint_len(N) + N * T::MAX_SIZE;
}
