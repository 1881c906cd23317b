//! The GPU vocabulary of `restir_world::gpu`: a binding set binds by name and refuses a
//! missing, unknown, repeated or wrongly shaped binding; every composed module declares, at
//! each (group, binding), the buffer its binding set names there.

use restir_world::gpu::{Access, BindingSet, Resource, Tracer};
use restir_world::{render, trace};
use tests::{buffers, gpu, wgsl};

fn set() -> BindingSet {
    BindingSet::new("test")
        .buffer("a", "array<u32>", Access::Read)
        .buffer("b", "array<u32>", Access::ReadWrite)
}

#[test]
fn bind_checks_every_name() {
    let ctx = gpu::context();
    let device = &ctx.device;
    let layout = set().layout(device);
    let x = buffers::storage_zeroed(device, "x", 16);
    let y = buffers::storage_zeroed(device, "y", 16);
    let bind = |res: Vec<(&str, Resource)>| layout.bind(device, res).map(drop);
    bind(vec![("a", (&x).into()), ("b", (&y).into())]).expect("both names");
    // Order does not matter: names do.
    bind(vec![("b", (&y).into()), ("a", (&x).into())]).expect("swapped order");
    let cases: [(Vec<(&str, Resource)>, &str); 4] = [
        (vec![("a", (&x).into())], "\"b\" is not bound"),
        (
            vec![("a", (&x).into()), ("b", (&y).into()), ("c", (&y).into())],
            "\"c\" is not declared",
        ),
        (
            vec![("a", (&x).into()), ("a", (&y).into()), ("b", (&y).into())],
            "\"a\" is bound twice",
        ),
        (
            vec![("a", Resource::Block(Vec::new())), ("b", (&y).into())],
            "wrong kind",
        ),
    ];
    for (res, want) in cases {
        let e = bind(res).expect_err(want).to_string();
        assert!(e.contains(want) && e.contains("\"test\""), "{e}");
    }
}

#[test]
fn wgsl_header_and_layout_agree() {
    let s = set().buffer("p", "vec4<u32>", Access::Uniform);
    let entries = s.layout_entries();
    assert_eq!(entries.len(), 3);
    assert_eq!(s.storage_buffers(), 2);
    let header = s.wgsl(5);
    for (line, entry) in header.lines().zip(&entries) {
        assert!(
            line.starts_with(&format!("@group(5) @binding({})", entry.binding)),
            "{line}"
        );
    }
    assert!(header.contains("var<uniform> p: vec4<u32>"));
}

/// Every binding naga finds in the composed renderer and tracer modules is the one the
/// binding sets declare at that (group, binding), by name. Planted fault: the same check
/// against a declaration with two names swapped must find the mismatch.
#[test]
fn composed_modules_bind_what_the_sets_declare() {
    let declared: Vec<Vec<String>> = render::shared_bindings(Tracer::Bvh)
        .iter()
        .enumerate()
        .map(|(g, set)| names(&set.wgsl(g as u32)))
        .collect();
    let mut swapped = declared.clone();
    swapped[0].swap(2, 3);
    for (name, source, groups) in [
        ("render", render::passes_source(Tracer::Bvh), 0..3),
        ("trace_rays", trace::kernel_source(Tracer::Bvh), 1..2),
    ] {
        let module = wgsl::validate(name, &source).expect("valid");
        let (checked, wrong) = check(&module, &declared, groups.clone());
        assert!(checked >= 2, "{name}: only {checked} bindings checked");
        assert!(wrong.is_empty(), "{name}: {wrong:?}");
        if name == "render" {
            let (_, wrong) = check(&module, &swapped, groups);
            assert_eq!(wrong.len(), 2, "planted swap not found: {wrong:?}");
        }
    }
}

/// (bindings checked, mismatches) of `module`'s globals in `groups` against `declared`.
fn check(
    module: &naga::Module,
    declared: &[Vec<String>],
    groups: std::ops::Range<u32>,
) -> (usize, Vec<String>) {
    let mut checked = 0;
    let mut wrong = Vec::new();
    for (_, var) in module.global_variables.iter() {
        let Some(b) = &var.binding else { continue };
        if !groups.contains(&b.group) {
            continue;
        }
        let want = &declared[b.group as usize][b.binding as usize];
        if var.name.as_deref() != Some(want.as_str()) {
            wrong.push(format!("{b:?}: {:?}, declared {want}", var.name));
        }
        checked += 1;
    }
    (checked, wrong)
}

/// Variable names of a binding header, in binding order.
fn names(header: &str) -> Vec<String> {
    header
        .lines()
        .filter_map(|l| l.split("> ").nth(1)?.split(':').next())
        .map(str::to_owned)
        .collect()
}
