//! The GPU vocabulary of `restir_world::gpu`: a binding set binds by name and refuses a
//! missing, unknown, repeated or wrongly shaped binding; every composed module declares, at
//! each (group, binding), the buffer its binding set names there.

use restir_world::gpu::{Access, BindingSet, Resource};
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
/// binding sets declare at that (group, binding), by name.
#[test]
fn composed_modules_bind_what_the_sets_declare() {
    let declared: Vec<(u32, Vec<String>)> = render::shared_bindings()
        .iter()
        .enumerate()
        .map(|(g, set)| (g as u32, names(&set.wgsl(g as u32))))
        .collect();
    for (name, source) in [
        ("render", render::passes_source()),
        ("trace_rays", trace::kernel_source()),
    ] {
        let module = wgsl::validate(name, &source).expect("valid");
        let mut checked = 0;
        for (_, var) in module.global_variables.iter() {
            let Some(b) = &var.binding else { continue };
            let Some((_, names)) = declared.iter().find(|(g, _)| *g == b.group) else {
                continue;
            };
            if name == "trace_rays" && b.group != 1 {
                continue;
            }
            let want = &names[b.binding as usize];
            assert_eq!(var.name.as_deref(), Some(want.as_str()), "{name}: {b:?}");
            checked += 1;
        }
        assert!(checked >= 2, "{name}: only {checked} bindings checked");
    }
}

/// Variable names of a binding header, in binding order.
fn names(header: &str) -> Vec<String> {
    header
        .lines()
        .filter_map(|l| l.split("> ").nth(1)?.split(':').next())
        .map(str::to_owned)
        .collect()
}
