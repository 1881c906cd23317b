//! The WGSL composer: each module names what it needs; [`compose`] orders them.

/// One piece of WGSL: a name, the modules it needs before it, and its source.
#[derive(Debug, Clone)]
pub struct WgslModule {
    pub name: String,
    pub needs: Vec<String>,
    pub source: String,
}

impl WgslModule {
    pub fn new(name: &str, needs: &[&str], source: impl Into<String>) -> Self {
        Self {
            name: name.to_owned(),
            needs: needs.iter().map(|s| (*s).to_owned()).collect(),
            source: source.into(),
        }
    }
}

/// Concatenates `modules` so that each comes after every module it needs (depth first, in the
/// order given otherwise); `enable` directives, which WGSL wants before any declaration, are
/// moved to the top. An unknown need or a cycle is an error naming it.
pub fn compose(modules: &[WgslModule]) -> Result<String, String> {
    fn visit<'m>(
        m: &'m WgslModule,
        all: &'m [WgslModule],
        state: &mut Vec<(&'m str, bool)>,
        out: &mut Vec<&'m str>,
    ) -> Result<(), String> {
        match state.iter().find(|(n, _)| *n == m.name) {
            Some((_, true)) => return Ok(()),
            Some((_, false)) => return Err(format!("WGSL module {:?} needs itself", m.name)),
            None => state.push((&m.name, false)),
        }
        for need in &m.needs {
            let dep = all.iter().find(|d| &d.name == need).ok_or_else(|| {
                format!(
                    "WGSL module {:?} needs {need:?}, which is not composed",
                    m.name
                )
            })?;
            visit(dep, all, state, out)?;
        }
        if let Some(s) = state.iter_mut().find(|(n, _)| *n == m.name) {
            s.1 = true;
        }
        out.push(&m.source);
        Ok(())
    }
    let mut state = Vec::new();
    let mut out = Vec::new();
    for m in modules {
        visit(m, modules, &mut state, &mut out)?;
    }
    let source = out.join("\n");
    let is_enable = |l: &&str| l.trim_start().starts_with("enable ");
    let mut enables: Vec<&str> = source.lines().filter(is_enable).collect();
    enables.sort_unstable();
    enables.dedup();
    if enables.is_empty() {
        return Ok(source);
    }
    let rest: Vec<&str> = source.lines().filter(|l| !is_enable(l)).collect();
    Ok(format!("{}\n{}", enables.join("\n"), rest.join("\n")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needs_come_first_and_errors_name_the_module() {
        let m = |n: &str, needs: &[&str]| WgslModule::new(n, needs, n);
        let s = compose(&[
            m("kernel", &["lib", "consts"]),
            m("lib", &["consts"]),
            m("consts", &[]),
        ])
        .unwrap();
        assert_eq!(s, "consts\nlib\nkernel");
        let e = compose(&[m("a", &["b"])]).unwrap_err();
        assert!(e.contains("\"b\""), "{e}");
        let e = compose(&[m("a", &["b"]), m("b", &["a"])]).unwrap_err();
        assert!(e.contains("needs itself"), "{e}");
        let s = compose(&[m("x", &[]), WgslModule::new("y", &["x"], "enable f16;\ny")]).unwrap();
        assert_eq!(s, "enable f16;\nx\ny");
        let e = compose(&[m("a", &["b"]), m("b", &["a"])]).unwrap_err();
        assert!(e.contains("needs itself"), "{e}");
    }
}
