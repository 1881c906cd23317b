//! GPU tests of the reservoir crate's reuse primitive (`reuse_*` WGSL) against its Rust twin
//! (`reservoir::reuse::Reuse`): many random combinations in every mode, with the hard cases
//! mixed in (zero targets on the receiver's and on the neighbours' side, invalid W, confidences
//! that saturate u32, M caps, a selected neighbour dropped before the end as a pass that finds
//! its sample occluded does). Selections, confidences and Z match exactly; the weights, which
//! pass through WGSL divisions (2.5 ulp allowed each), within a few ulp.

use reservoir::PackedReservoir;
use reservoir::reuse::{CANONICAL, Combination, Reuse, cap_m};
use reservoir::rng::Rng;
use restir_world::gpu::{Access, BindingSet, WORKGROUP_SIZE};
use tests::{buffers, gpu};

/// One receiver: its mode, own reservoir and target, and where its neighbours start.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Case {
    mode: u32,
    k: u32,
    own_ucw: f32,
    own_m: u32,
    p_own: f32,
    u_own: f32,
    first: u32,
    /// 1: a selected neighbour is dropped before the end (`reuse_drop_neighbours`).
    drop: u32,
}

/// One neighbour: its reservoir, cap, targets and random number.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Neighbour {
    ucw: f32,
    m: u32,
    cap: u32,
    p_here: f32,
    p_n_y: f32,
    p_n_own: f32,
    u: f32,
    p_n_selected: f32,
}

/// What a combination ends with.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct Out {
    ucw: f32,
    m: u32,
    selected: u32,
    p_hat: f32,
    z: u32,
    canonical: f32,
    total: f32,
    r_m: u32,
}

const KERNEL: &str = "
struct Case { mode: u32, k: u32, own_ucw: f32, own_m: u32, p_own: f32, u_own: f32, first: u32, drop: u32 }
struct Neighbour { ucw: f32, m: u32, cap: u32, p_here: f32, p_n_y: f32, p_n_own: f32, u: f32, p_n_selected: f32 }
struct Out { ucw: f32, m: u32, selected: u32, p_hat: f32, z: u32, canonical: f32, total: f32, r_m: u32 }

@compute @workgroup_size(WORKGROUP_SIZE)
fn combine(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) { return; }
    let cs = cases[i];
    var m_n = 0u;
    for (var j = 0u; j < cs.k; j++) {
        let nb = neighbours[cs.first + j];
        m_n = reservoir_add_m(m_n, reuse_cap_m(nb.m, nb.cap));
    }
    var c = reuse_begin(cs.mode, PackedReservoir(cs.own_ucw, cs.own_m), cs.p_own, cs.k, m_n, cs.u_own);
    for (var j = 0u; j < cs.k; j++) {
        let nb = neighbours[cs.first + j];
        let other = PackedReservoir(nb.ucw, reuse_cap_m(nb.m, nb.cap));
        reuse_neighbour(&c, j, other, nb.p_here, nb.p_n_y, nb.p_n_own, nb.u);
    }
    for (var j = 0u; j < cs.k; j++) {
        let nb = neighbours[cs.first + j];
        reuse_count_z(&c, reuse_cap_m(nb.m, nb.cap), nb.p_n_selected);
    }
    if cs.drop != 0u && reuse_selected(c) != REUSE_CANONICAL {
        reuse_drop_neighbours(&c);
    }
    let stored = reuse_finish(&c);
    outs[i] = Out(stored.ucw, stored.m, reuse_selected(c), c.p_hat, c.z, c.canonical,
                  reservoir_total(c.r), c.r.m);
}
";

/// The twin's run of one case.
fn twin(cs: &Case, nbs: &[Neighbour]) -> Out {
    let nbs = &nbs[cs.first as usize..(cs.first + cs.k) as usize];
    let m_n = nbs
        .iter()
        .fold(0u32, |a, n| a.saturating_add(cap_m(n.m, n.cap)));
    let mode = Combination::ALL[cs.mode as usize].0;
    let own = PackedReservoir {
        ucw: cs.own_ucw,
        m: cs.own_m,
    };
    let mut c = Reuse::begin(mode, own, cs.p_own, cs.k, m_n, cs.u_own);
    for (j, n) in nbs.iter().enumerate() {
        let other = PackedReservoir {
            ucw: n.ucw,
            m: cap_m(n.m, n.cap),
        };
        c.neighbour(j as u32, other, n.p_here, n.p_n_y, n.p_n_own, n.u);
    }
    for n in nbs {
        c.count_z(cap_m(n.m, n.cap), n.p_n_selected);
    }
    if cs.drop != 0 && c.selected() != CANONICAL {
        c.drop_neighbours();
    }
    let stored = c.finish();
    Out {
        ucw: stored.ucw,
        m: stored.m,
        selected: c.selected(),
        p_hat: c.p_hat,
        z: c.z,
        canonical: c.canonical,
        total: c.r.total(),
        r_m: c.r.m,
    }
}

fn run_on_gpu(kernel_src: &str, cases: &[Case], nbs: &[Neighbour]) -> Vec<Out> {
    let ctx = gpu::context();
    let set = BindingSet::new("reuse test")
        .buffer("cases", "array<Case>", Access::Read)
        .buffer("neighbours", "array<Neighbour>", Access::Read)
        .buffer("outs", "array<Out>", Access::ReadWrite);
    let (kernel, layout) =
        gpu::reservoir_kernel("reuse test", &set, kernel_src, &["combine"], WORKGROUP_SIZE);
    let case_buf = buffers::storage_from(&ctx.device, "cases", cases);
    let nb_buf = buffers::storage_from(&ctx.device, "neighbours", nbs);
    let bytes = (cases.len() * size_of::<Out>()) as u64;
    let out_buf = buffers::storage_zeroed(&ctx.device, "outs", bytes);
    let res = [
        ("cases", (&case_buf).into()),
        ("neighbours", (&nb_buf).into()),
        ("outs", (&out_buf).into()),
    ];
    let group = layout.bind(&ctx.device, res).expect("bind");
    let pass = kernel.pass(&ctx.device, "combine", &[&group], cases.len() as u32);
    gpu::run(ctx, |enc| pass.record(enc));
    buffers::read_range(ctx, &out_buf, 0, bytes).expect("readback")
}

/// A target value: log-uniform over 1e-20..1e20, zero a fifth of the time.
fn target(rng: &mut Rng) -> f32 {
    if rng.next_f32() < 0.2 {
        return 0.0;
    }
    10f32.powf(40.0 * rng.next_f32() - 20.0)
}

/// A confidence: mostly small, sometimes 0, sometimes near u32::MAX (saturating sums).
fn confidence(rng: &mut Rng) -> u32 {
    match rng.next_u32() % 10 {
        0 => 0,
        1 => u32::MAX - rng.next_u32() % 4,
        _ => 1 + rng.next_u32() % 400,
    }
}

/// A stored W: log-uniform, sometimes 0, NaN or Inf (read from a damaged buffer).
fn ucw(rng: &mut Rng) -> f32 {
    match rng.next_u32() % 20 {
        0 => 0.0,
        1 => f32::NAN,
        2 => f32::INFINITY,
        _ => 10f32.powf(30.0 * rng.next_f32() - 15.0),
    }
}

fn random_cases(seed: u32, count: u32) -> (Vec<Case>, Vec<Neighbour>) {
    let mut rng = Rng::seed(seed, 0, 0);
    let (mut cases, mut nbs) = (Vec::new(), Vec::new());
    for i in 0..count {
        let k = rng.next_u32() % 7;
        cases.push(Case {
            mode: i % 3,
            k,
            own_ucw: ucw(&mut rng),
            own_m: confidence(&mut rng),
            p_own: target(&mut rng),
            u_own: rng.next_f32(),
            first: nbs.len() as u32,
            drop: u32::from(i % 5 == 1),
        });
        for _ in 0..k {
            let cap = match rng.next_u32() % 3 {
                0 => u32::MAX,
                _ => 1 + rng.next_u32() % 64,
            };
            nbs.push(Neighbour {
                ucw: ucw(&mut rng),
                m: confidence(&mut rng),
                cap,
                p_here: target(&mut rng),
                p_n_y: target(&mut rng),
                p_n_own: target(&mut rng),
                u: rng.next_f32(),
                p_n_selected: target(&mut rng),
            });
        }
    }
    (cases, nbs)
}

fn ulps(a: f32, b: f32) -> u32 {
    a.to_bits().abs_diff(b.to_bits())
}

/// 6000 combinations (2000 per mode), 0..6 neighbours each, hard cases mixed in.
#[test]
fn gpu_combinations_match_the_twin() {
    const MAX_ULPS: u32 = 16;
    let (cases, nbs) = random_cases(11, 6000);
    let gpu_out = run_on_gpu(KERNEL, &cases, &nbs);
    let mut worst = 0;
    for (i, (cs, g)) in cases.iter().zip(&gpu_out).enumerate() {
        let t = twin(cs, &nbs);
        let exact = (g.m, g.selected, g.z, g.r_m, g.p_hat.to_bits());
        assert_eq!(
            exact,
            (t.m, t.selected, t.z, t.r_m, t.p_hat.to_bits()),
            "case {i} {cs:?}: {g:?} vs {t:?}"
        );
        for (name, a, b) in [
            ("ucw", g.ucw, t.ucw),
            ("canonical", g.canonical, t.canonical),
            ("total", g.total, t.total),
        ] {
            assert!(a.is_finite(), "case {i}: GPU {name} = {a}");
            worst = worst.max(ulps(a, b));
            assert!(
                ulps(a, b) <= MAX_ULPS,
                "case {i} {name}: GPU {a} vs twin {b}"
            );
        }
    }
    eprintln!("reuse GPU vs twin: worst {worst} ulp (allowed {MAX_ULPS})");
    // The hard cases happened: saturated confidences, canonical and neighbour selections.
    assert!(gpu_out.iter().any(|o| o.m == u32::MAX));
    assert!(
        gpu_out
            .iter()
            .any(|o| o.selected == CANONICAL && o.ucw > 0.0)
    );
    assert!(gpu_out.iter().any(|o| o.selected != CANONICAL));
    // And pairwise combinations that had selected a neighbour fell back to the receiver's own
    // sample when it was dropped.
    let pairwise = Combination::Pairwise as u32;
    let fell_back = cases.iter().zip(&gpu_out).filter(|(cs, o)| {
        let kept = Case { drop: 0, ..**cs };
        cs.drop == 1
            && cs.mode == pairwise
            && twin(&kept, &nbs).selected != CANONICAL
            && o.selected == CANONICAL
            && o.ucw > 0.0
    });
    assert!(fell_back.count() > 10);
}

/// Control: a defect planted on the GPU only (every neighbour's target at the receiver halved,
/// as a wrong Jacobian would) is caught by the same comparison: more than 1 in 10 combinations
/// differ (measured 94 of 600; 0..6 neighbours each, a fifth of them dropped before the end,
/// where the defect changes nothing, and some with no neighbour or no weight at all).
#[test]
fn a_planted_gpu_defect_is_caught() {
    let (cases, nbs) = random_cases(12, 600);
    let planted = KERNEL.replace(
        "reuse_neighbour(&c, j, other, nb.p_here,",
        "reuse_neighbour(&c, j, other, 0.5 * nb.p_here,",
    );
    assert_ne!(planted, KERNEL);
    let differs = run_on_gpu(&planted, &cases, &nbs)
        .iter()
        .zip(&cases)
        .filter(|(g, cs)| {
            let t = twin(cs, &nbs);
            g.selected != t.selected || ulps(g.ucw, t.ucw) > 16
        })
        .count();
    assert!(differs > 60, "only {differs} of 600 combinations differ");
}
