//! The equal-time comparison: each other method at the samples per pixel per frame that fit
//! the target's GPU time per frame, its error against the target's.

use anyhow::Result;
use restir_world::methods::MethodSettings;

use super::CompareOptions;
use super::method_run::SceneRuns;
use super::report::{EqualTime, EqualTimeEntry, EqualTimeImage, Err2, MethodRun, PerImage};

/// Most samples per pixel per frame an equal-time run takes.
const MAX_SPP: u32 = 4096;

/// Runs the comparison against the target of `runs` (none without one or without times).
pub fn compare(job: &SceneRuns, runs: &[MethodRun]) -> Result<Option<EqualTime>> {
    let Some(t) = equal_time_target(job.opts, job.settings, runs) else {
        return Ok(None);
    };
    let target = &runs[t];
    let Some(target_ms) = target.ms_per_frame_median else {
        return Ok(None);
    };
    let mut entries = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        if i == t || run.planted_bias.is_some() {
            continue;
        }
        let Some(ms) = run.ms_per_frame_median else {
            continue;
        };
        let spp = ((target_ms / ms.max(1e-9)).floor() as u32).clamp(1, MAX_SPP);
        let entry = if spp == 1 {
            entry(run, spp, target, target_ms)
        } else {
            entry(&job.run_equal_time(i, spp)?, spp, target, target_ms)
        };
        entries.push(entry);
    }
    Ok(Some(EqualTime {
        target: target.method.clone(),
        target_ms_per_frame: target_ms,
        target_frame: target.frame_errors(),
        entries,
    }))
}

/// The method equal-time comparisons are measured against: `--equal-time-to`, else the first
/// listed method the registry marks as the target (world-space ReSTIR), else the slowest.
fn equal_time_target(
    opts: &CompareOptions,
    settings: &[MethodSettings],
    runs: &[MethodRun],
) -> Option<usize> {
    if let Some(t) = &opts.equal_time_to {
        return runs.iter().position(|r| &r.method == t);
    }
    if let Some(i) = (runs.iter().zip(settings))
        .position(|(r, s)| s.entry.equal_time_target && r.planted_bias.is_none())
    {
        return Some(i);
    }
    runs.iter()
        .enumerate()
        .filter(|(_, r)| r.planted_bias.is_none())
        .filter_map(|(i, r)| r.ms_per_frame_median.map(|ms| (i, ms)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// `run` (at `spp` samples per pixel per frame) against `target`, image by image.
fn entry(run: &MethodRun, spp: u32, target: &MethodRun, target_ms: f64) -> EqualTimeEntry {
    let rel: fn(&Err2) -> f64 = |e| e.rel_mse;
    let trim: fn(&Err2) -> f64 = |e| e.rel_mse_trimmed;
    let ms = run.ms_per_frame_median;
    // The time to the target's error (1/N variance law) over the target's time.
    let speedup = |ratio: Option<f64>| Some(ms? * ratio? / target_ms);
    let images = PerImage::from_fn(|k| {
        let (e, te) = (run.images.get(k).frame, target.images.get(k).frame);
        EqualTimeImage {
            frame: e,
            rel_mse_ratio: ratio(e, te, rel),
            rel_mse_trimmed_ratio: ratio(e, te, trim),
            equal_error_speedup: speedup(ratio(e, te, rel)),
            equal_error_speedup_trimmed: speedup(ratio(e, te, trim)),
        }
    });
    EqualTimeEntry {
        method: run.method.clone(),
        spp_per_frame: spp,
        ms_per_frame: ms,
        images,
    }
}

/// `pick(a) / pick(b)`, when both are there and `pick(b)` is positive.
fn ratio(a: Option<Err2>, b: Option<Err2>, pick: fn(&Err2) -> f64) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if pick(&b) > 0.0 => Some(pick(&a) / pick(&b)),
        _ => None,
    }
}
