//! `--bounces`, `--roulette-from`, `--mis`: the depth of the indirect paths, the same for every
//! method and for the references (render, compare, view).

use anyhow::{Result, bail};
use restir_world::render::{DEFAULT_ROULETTE_FROM, MAX_BOUNCES, Paths};

/// The path flags.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct PathArgs {
    /// Bounces of indirect light, 1..=64: the indirect image holds bounces 1..N (beyond the
    /// secondary vertex the path continues by cosine sampling, with the method's light
    /// estimate at every vertex). The cost grows with N.
    #[arg(long, default_value_t = Paths::default().bounces)]
    pub bounces: u32,
    /// Russian roulette from this bounce on (0: never).
    #[arg(long, default_value_t = DEFAULT_ROULETTE_FROM)]
    pub roulette_from: u32,
    /// Multiple importance sampling of the light reached both ways (a light sample and a ray
    /// that hits the emitter): on or off.
    // `Set`: a bool field would default to a flag (`SetTrue`) and hand the parser "true".
    #[arg(long, action = clap::ArgAction::Set, value_parser = parse_on_off,
          default_value = if Paths::default().mis { "on" } else { "off" })]
    pub mis: bool,
}

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("expected on or off, got {s:?}")),
    }
}

impl PathArgs {
    /// The paths, checked (before any GPU work; the light estimator's candidates are checked
    /// against the depth when a method is built).
    pub fn paths(&self) -> Result<Paths> {
        let p = Paths {
            bounces: self.bounces,
            roulette_from: self.roulette_from,
            mis: self.mis,
        };
        if let Err(e) = p.check(1) {
            bail!("--bounces / --roulette-from: {e} (--bounces at most {MAX_BOUNCES})");
        }
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        paths: PathArgs,
    }

    fn parse(args: &[&str]) -> Result<Paths, String> {
        let cli = Cli::try_parse_from(std::iter::once("x").chain(args.iter().copied()))
            .map_err(|e| e.to_string())?;
        cli.paths.paths().map_err(|e| e.to_string())
    }

    #[test]
    fn flags_parse_to_paths() {
        assert_eq!(parse(&[]).unwrap(), Paths::default());
        let p = parse(&["--bounces", "5", "--roulette-from", "0", "--mis", "on"]).unwrap();
        assert_eq!((p.bounces, p.roulette_from, p.mis), (5, 0, true));
        assert!(!parse(&["--mis", "off"]).unwrap().mis);
        assert!(
            parse(&["--mis", "maybe"])
                .unwrap_err()
                .contains("expected on or off")
        );
        assert!(parse(&["--mis"]).is_err());
        assert!(
            parse(&["--bounces", "65"])
                .unwrap_err()
                .contains("--bounces")
        );
    }
}
