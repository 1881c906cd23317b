//! CPU twins of the scan: the plain serial scan the GPU results are compared with, and a
//! model of the kernel's tile loop (tickets, published states, look-back, fallback) that runs
//! the same state machine on the CPU under an adversarial schedule.

use crate::ScanKind;
use crate::state::{self, FLAG_AGGREGATE, FLAG_PREFIX, TileState};

/// Serial prefix sum modulo 2^32.
pub fn scan(input: &[u32], kind: ScanKind) -> Vec<u32> {
    let mut out = Vec::with_capacity(input.len());
    let mut sum = 0u32;
    for &x in input {
        match kind {
            ScanKind::Exclusive => {
                out.push(sum);
                sum = sum.wrapping_add(x);
            }
            ScanKind::Inclusive => {
                sum = sum.wrapping_add(x);
                out.push(sum);
            }
        }
    }
    out
}

/// Sum modulo 2^32 (the total the scan optionally writes).
pub fn total(input: &[u32]) -> u32 {
    input.iter().fold(0u32, |a, &x| a.wrapping_add(x))
}

/// What the tile model did, for tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ModelStats {
    /// Predecessor states consumed by look-backs.
    pub lookback_steps: u64,
    /// Predecessor tiles reduced by a waiting tile (the fallback).
    pub fallbacks: u64,
}

/// Runs the kernel's algorithm tile by tile on the CPU: tiles of `tile_len` elements in ticket
/// order, each publishing its aggregate, looking back over its predecessors' packed states
/// ([`crate::state`]) and publishing its inclusive prefix.
///
/// `stalled(t)` models a workgroup that got ticket `t` and then made no progress: it publishes
/// nothing until every later tile has finished, so its successors must take the fallback (reduce
/// its input themselves and publish its aggregate with max). The stalled tiles finish last.
pub fn tiled_scan_model(
    input: &[u32],
    kind: ScanKind,
    tile_len: usize,
    stalled: impl Fn(usize) -> bool,
) -> (Vec<u32>, ModelStats) {
    assert!(tile_len > 0);
    let tiles = input.len().div_ceil(tile_len).max(1);
    let mut states = vec![[0u32; 2]; tiles];
    let mut out = vec![0u32; input.len()];
    let mut stats = ModelStats::default();
    let range = |t: usize| t * tile_len..((t + 1) * tile_len).min(input.len());

    let mut run_tile = |t: usize, states: &mut Vec<[u32; 2]>, stats: &mut ModelStats| {
        let aggregate = total(&input[range(t)]);
        let mut prefix = 0u32;
        if t == 0 {
            state::publish(&mut states[0], FLAG_PREFIX, aggregate);
        } else {
            state::publish(&mut states[t], FLAG_AGGREGATE, aggregate);
            let mut j = t - 1;
            loop {
                match state::unpack(states[j]) {
                    TileState::Prefix(v) => {
                        prefix = prefix.wrapping_add(v);
                        stats.lookback_steps += 1;
                        break;
                    }
                    TileState::Aggregate(v) => {
                        prefix = prefix.wrapping_add(v);
                        stats.lookback_steps += 1;
                    }
                    TileState::Pending => {
                        // On the CPU nothing changes while we wait: fall back at once.
                        let agg = total(&input[range(j)]);
                        let flag = if j == 0 { FLAG_PREFIX } else { FLAG_AGGREGATE };
                        state::publish(&mut states[j], flag, agg);
                        prefix = prefix.wrapping_add(agg);
                        stats.fallbacks += 1;
                        if j == 0 {
                            break;
                        }
                    }
                }
                if j == 0 {
                    break;
                }
                j -= 1;
            }
            state::publish(&mut states[t], FLAG_PREFIX, prefix.wrapping_add(aggregate));
        }
        let r = range(t);
        let scanned = scan(&input[r.clone()], kind);
        for (o, s) in out[r].iter_mut().zip(scanned) {
            *o = prefix.wrapping_add(s);
        }
    };

    let order: Vec<usize> = (0..tiles)
        .filter(|&t| !stalled(t))
        .chain((0..tiles).filter(|&t| stalled(t)))
        .collect();
    for t in order {
        run_tile(t, &mut states, &mut stats);
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    fn random(n: usize, seed: u64) -> Vec<u32> {
        let mut rng = StdRng::seed_from_u64(seed);
        (0..n).map(|_| rng.random()).collect()
    }

    #[test]
    fn serial_scan_wraps_modulo_2_32() {
        let input = [u32::MAX, 2, u32::MAX];
        assert_eq!(scan(&input, ScanKind::Exclusive), [0, u32::MAX, 1]);
        assert_eq!(scan(&input, ScanKind::Inclusive), [u32::MAX, 1, 0]);
        assert_eq!(total(&input), 0);
        assert!(scan(&[], ScanKind::Exclusive).is_empty());
    }

    #[test]
    fn tile_model_matches_serial_scan_without_stalls() {
        for (n, tile) in [(0, 4), (1, 4), (7, 4), (8, 4), (9, 4), (1000, 32)] {
            let input = random(n, n as u64);
            for kind in [ScanKind::Exclusive, ScanKind::Inclusive] {
                let (got, stats) = tiled_scan_model(&input, kind, tile, |_| false);
                assert_eq!(got, scan(&input, kind), "n={n} tile={tile}");
                assert_eq!(stats.fallbacks, 0);
            }
        }
    }

    #[test]
    fn tile_model_falls_back_past_stalled_tiles() {
        let input = random(10_000, 7);
        let stall_patterns: [&dyn Fn(usize) -> bool; 4] =
            [&|t| t == 0, &|t| t % 3 == 1, &|t| t < 50, &|t| t % 2 == 0];
        for stalled in stall_patterns {
            let (got, stats) = tiled_scan_model(&input, ScanKind::Exclusive, 64, stalled);
            assert_eq!(got, scan(&input, ScanKind::Exclusive));
            assert!(stats.fallbacks > 0, "the stalls must force the fallback");
        }
    }

    #[test]
    fn tile_model_detects_a_planted_error() {
        // Negative control: corrupting one published state must break the result.
        let input = random(1000, 3);
        let (mut got, _) = tiled_scan_model(&input, ScanKind::Inclusive, 16, |_| false);
        got[500] ^= 1;
        assert_ne!(got, scan(&input, ScanKind::Inclusive));
    }
}
