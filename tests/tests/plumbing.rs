//! The GPU vocabulary of `restir_world::gpu`: a binding set binds by name and refuses a
//! missing, unknown, repeated or wrongly shaped binding; every composed module declares, at
//! each (group, binding), the buffer its binding set names there.

use restir_world::gpu::{Access, BindingSet, Resource};
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

/// Every kernel the renderer and its stages create (`restir_world::kernels()`): each binding
/// naga finds in its composed source has an entry at that (group, binding) of the pipeline
/// layout its binding sets make, of the same kind (uniform, read-only or read-write storage,
/// acceleration structure), and the buffer the set names there; and every layout entry is
/// declared in the source. Control: the same check of a layout with one entry's access
/// changed must find the mismatch.
#[test]
fn every_kernel_declares_what_its_layout_binds() {
    let kernels = restir_world::kernels();
    assert!(kernels.len() >= 10, "only {} kernels", kernels.len());
    for k in &kernels {
        let module = wgsl::validate(&k.name, &k.source).expect("valid");
        let layouts: Vec<_> = k.groups.iter().map(|s| s.layout_entries()).collect();
        let names: Vec<_> = k.groups.iter().map(|s| s.binding_names()).collect();
        let wrong = check(&module, &layouts, &names);
        assert!(wrong.is_empty(), "{}: {wrong:?}", k.name);
    }
    // Control: flip the access of the first storage buffer of the render group.
    let k = &kernels[0];
    let module = wgsl::validate(&k.name, &k.source).expect("valid");
    let mut layouts: Vec<_> = k.groups.iter().map(|s| s.layout_entries()).collect();
    let names: Vec<_> = k.groups.iter().map(|s| s.binding_names()).collect();
    let e = layouts[0]
        .iter_mut()
        .find(|e| {
            matches!(
                e.ty,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { .. },
                    ..
                }
            )
        })
        .expect("a storage buffer");
    e.ty = wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    assert_eq!(
        check(&module, &layouts, &names).len(),
        1,
        "planted access change not found"
    );
}

/// The mismatches between `module`'s bound globals and the pipeline layout `layouts` (one
/// entry list per group) whose buffers `names` names.
fn check(
    module: &naga::Module,
    layouts: &[Vec<wgpu::BindGroupLayoutEntry>],
    names: &[Vec<Option<&str>>],
) -> Vec<String> {
    let mut wrong = Vec::new();
    let mut seen = 0;
    for (_, var) in module.global_variables.iter() {
        let Some(b) = &var.binding else { continue };
        seen += 1;
        let entry = layouts
            .get(b.group as usize)
            .and_then(|g| g.iter().find(|e| e.binding == b.binding));
        let Some(entry) = entry else {
            wrong.push(format!("{b:?} {:?}: not in the layout", var.name));
            continue;
        };
        let kind = match var.space {
            naga::AddressSpace::Uniform => "uniform",
            naga::AddressSpace::Storage { access }
                if access.contains(naga::StorageAccess::STORE) =>
            {
                "read-write"
            }
            naga::AddressSpace::Storage { .. } => "read-only",
            _ => "other",
        };
        let want = match entry.ty {
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                ..
            } => "uniform",
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                ..
            } => "read-only",
            wgpu::BindingType::Buffer { .. } => "read-write",
            _ => "other",
        };
        if kind != want {
            wrong.push(format!(
                "{b:?} {:?}: {kind} in WGSL, {want} in the layout",
                var.name
            ));
        }
        let named = names
            .get(b.group as usize)
            .and_then(|n| n.get(b.binding as usize));
        if let (Some(Some(want)), Some(got)) = (named, &var.name)
            && want != got
        {
            wrong.push(format!("{b:?}: {got:?}, declared {want}"));
        }
    }
    let entries: usize = layouts.iter().map(Vec::len).sum();
    if seen != entries {
        wrong.push(format!("{seen} bound globals, {entries} layout entries"));
    }
    wrong
}
