//! The packed tile state of the look-back, shared with the WGSL kernel (which gets these
//! constants through the generated header).
//!
//! A tile's state is two atomic `u32` words: `flag | low 16 bits` and `flag | high 16 bits` of
//! its value, flags in the two high bits. A full `u32` value and a flag do not fit in one word,
//! so the value is split; each half travels with its own copy of the flag. Flags only grow
//! (empty < aggregate < inclusive prefix) and every publisher of a given flag publishes the same
//! value (sums are unique modulo 2^32), so publishing with `atomicMax` can never move a word
//! backwards, whoever publishes and in whatever order. A reader trusts a state only when both
//! words carry the same flag; mixed flags mean a publish is in progress.

/// Flag: the value is the tile's own sum (aggregate).
pub const FLAG_AGGREGATE: u32 = 1 << 30;
/// Flag: the value is the inclusive prefix (sum of all tiles up to and including this one).
pub const FLAG_PREFIX: u32 = 2 << 30;
/// Mask of the flag bits.
pub const FLAG_MASK: u32 = 3 << 30;
/// Mask of the value half carried by each word.
pub const HALF_MASK: u32 = 0xFFFF;

/// What a reader can learn from a tile's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TileState {
    /// Nothing usable yet (nothing published, or a publish is half done).
    Pending,
    /// The tile's own sum.
    Aggregate(u32),
    /// The inclusive prefix through this tile.
    Prefix(u32),
}

/// The two words that publish `value` with `flag` ([`FLAG_AGGREGATE`] or [`FLAG_PREFIX`]).
pub fn pack(flag: u32, value: u32) -> [u32; 2] {
    [flag | (value & HALF_MASK), flag | (value >> 16)]
}

/// Decodes the two state words (as the kernel does).
pub fn unpack(words: [u32; 2]) -> TileState {
    let flag = words[0] & FLAG_MASK;
    if words[1] & FLAG_MASK != flag {
        return TileState::Pending;
    }
    let value = (words[0] & HALF_MASK) | (words[1] << 16);
    match flag {
        FLAG_AGGREGATE => TileState::Aggregate(value),
        FLAG_PREFIX => TileState::Prefix(value),
        _ => TileState::Pending,
    }
}

/// Publishes into `words` with `atomicMax` semantics, as the kernel does.
pub fn publish(words: &mut [u32; 2], flag: u32, value: u32) {
    let new = pack(flag, value);
    words[0] = words[0].max(new[0]);
    words[1] = words[1].max(new[1]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_extreme_values() {
        for v in [0, 1, 0xFFFF, 0x1_0000, 0x8000_0000, u32::MAX, 0xDEAD_BEEF] {
            assert_eq!(unpack(pack(FLAG_AGGREGATE, v)), TileState::Aggregate(v));
            assert_eq!(unpack(pack(FLAG_PREFIX, v)), TileState::Prefix(v));
        }
        assert_eq!(unpack([0, 0]), TileState::Pending);
    }

    #[test]
    fn state_never_moves_backwards_under_max() {
        // Any interleaving of the owner's publishes (aggregate, then prefix) and fallback
        // publishes of the aggregate ends in the prefix state, and never shows a mix of halves.
        let (agg, prefix) = (0xFFFF_0001u32, 0x0001_FFFFu32);
        let events = [
            (FLAG_AGGREGATE, agg),
            (FLAG_PREFIX, prefix),
            (FLAG_AGGREGATE, agg),
        ];
        for order in [
            [0, 1, 2],
            [0, 2, 1],
            [2, 0, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 1, 0],
        ] {
            let mut words = [0u32; 2];
            let mut best = 0;
            for &e in &order {
                let (flag, value) = events[e];
                publish(&mut words, flag, value);
                let rank = match unpack(words) {
                    TileState::Pending => 0,
                    TileState::Aggregate(v) => {
                        assert_eq!(v, agg);
                        1
                    }
                    TileState::Prefix(v) => {
                        assert_eq!(v, prefix);
                        2
                    }
                };
                assert!(rank >= best, "state moved backwards in order {order:?}");
                best = rank;
            }
            assert_eq!(unpack(words), TileState::Prefix(prefix));
        }
    }

    #[test]
    fn half_published_state_is_pending() {
        // Owner published the low word of the prefix but not yet the high word.
        let mut words = pack(FLAG_AGGREGATE, 7);
        words[0] = words[0].max(pack(FLAG_PREFIX, 9)[0]);
        assert_eq!(unpack(words), TileState::Pending);
        // Negative control: a decoder that ignored the high flag would read a wrong value.
        let naive = (words[0] & HALF_MASK) | ((words[1] & HALF_MASK) << 16);
        assert_eq!(naive, 9);
        assert_ne!(unpack(words), TileState::Prefix(naive));
    }
}
