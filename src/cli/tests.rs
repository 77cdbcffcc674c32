//! The argument layer under arbitrary input: never a panic, and every refusal names what
//! it refuses. Plans read and check everything but compute and write nothing, so they can
//! be made by the thousand.

use crate::*;
use fpsolve::mc::NamedGrid;
use proptest::prelude::*;

const TOKENS: &[&str] = &[
    "models/linear.sde",
    "models/vibro_duffing.sde",
    "models/nope.sde",
    "check",
    "solve",
    "simulate",
    "sweep",
    "merge",
    "--degree",
    "--set",
    "--mc",
    "--dt",
    "--spacing",
    "--burn-in",
    "--trajectories",
    "--grid",
    "--threads",
    "--seed",
    "--shard",
    "--samples",
    "--quiet",
    "--out",
    "--method",
    "epc,grid",
    "epc-impact",
    "grid",
    "--cells",
    "--domain",
    "x=-3:3,v=-4:4",
    "z=3:1,v=-4:4",
    "40,40",
    "41,40",
    "--mc-from",
    "2,4",
    "3",
    "4,4",
    "0",
    "-1",
    "1e300",
    "1e-300",
    "NaN",
    "inf",
    "mu=0.2",
    "eps=0:0.1:3",
    "mu=abc",
    "c=1/0",
    "y=0:8:10",
    "y=0:8:4294967297",
    "z=1:0:5",
    "3/2",
    "0/0",
    "18446744073709551615",
    "",
    "=",
    "/nonexistent/dir",
];

fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => proptest::sample::select(TOKENS).prop_map(String::from),
        1 => "[ -~]{0,12}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_arguments_never_panic_and_refusals_say_why(
        args in proptest::collection::vec(token(), 0..8)
    ) {
        let argv = std::iter::once("fpsolve".to_string()).chain(args.iter().cloned());
        match Cli::try_parse_from(argv) {
            // clap's own refusals name the argument; they exit 2 (or 0 for --help).
            Err(e) => prop_assert!(!e.to_string().is_empty()),
            Ok(cli) => {
                if let Err(e) = plan(cli) {
                    let text = format!("{e:#}");
                    prop_assert!(!text.trim().is_empty());
                    // It names a flag, or quotes what it refuses.
                    let quoted = args
                        .iter()
                        .any(|a| !a.is_empty() && text.contains(a.as_str()));
                    prop_assert!(
                        text.contains("--") || quoted || text.contains("no model file"),
                        "refusal names neither a flag nor what it refuses: {text}"
                    );
                }
            }
        }
    }

    #[test]
    fn well_formed_commands_with_arbitrary_values_never_panic(
        command in proptest::sample::select(&["", "solve", "simulate", "sweep", "check"][..]),
        model in proptest::sample::select(&TOKENS[..3]),
        pairs in proptest::collection::vec(
            (proptest::sample::select(&TOKENS[8..21]), token()), 0..5
        ),
    ) {
        let mut argv = vec!["fpsolve".to_string()];
        if !command.is_empty() {
            argv.push(command.to_string());
        }
        argv.push(model.to_string());
        for (flag, value) in &pairs {
            argv.push(format!("{flag}={value}"));
        }
        if let Ok(cli) = Cli::try_parse_from(&argv) {
            if let Err(e) = plan(cli) {
                let text = format!("{e:#}");
                let quoted = argv[1..].iter().any(|a| text.contains(a.as_str()));
                prop_assert!(
                    text.contains("--") || text.contains(".sde") || quoted,
                    "refusal names neither a flag nor what it refuses: {text}"
                );
            }
        }
    }

    #[test]
    fn grids_counts_and_shards_parse_or_say_which_flag(text in "[ -~]{0,24}") {
        let _ = text.parse::<NamedGrid>();
        let _ = text.parse::<Shard>();
        if let Err(e) = parse_count(&text, "--mc") {
            prop_assert!(e.to_string().contains("--mc"));
        }
        let _ = text.parse::<DegreeList>();
    }
}

#[test]
fn plans_compute_nothing_and_write_nothing() {
    let root = std::env::temp_dir().join(format!("fpsolve-plan-{}", std::process::id()));
    let out = root.join("out");
    let cli = Cli::try_parse_from([
        "fpsolve",
        "models/vibro_duffing.sde",
        "--mc",
        "1e5",
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let plan = plan(cli).unwrap();
    assert!(matches!(plan.plan, Plan::Job { .. }));
    assert!(!root.exists());
}
