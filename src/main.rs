//! The `fpsolve` command line: argument parsing and calls into the library, nothing more.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use fpsolve::fpk::FpkOperator;
use fpsolve::job::{self, JobSpec, Progress, Target};
use fpsolve::mc::{merge_named, BurnIn, Grid, McConfig, Shard, ShardOutput, Simulation};
use fpsolve::model::{load_model, parse_expr, Model, Override};
use fpsolve::report::{write_json, OutputDir};
use fpsolve::sweep::{Sweep, SweepSpec};

/// Stationary PDFs of randomly excited nonlinear oscillators.
///
/// `fpsolve MODEL` runs the main job: EPC at degrees 2 and 4, the PDFs of every observable,
/// a table, CSV files, summary.json and figures in out/<model>/.
#[derive(Parser, Debug)]
#[command(
    name = "fpsolve",
    version,
    about,
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Args, Debug)]
struct RunArgs {
    /// The model file (`.sde`).
    model: Option<PathBuf>,
    #[command(flatten)]
    solve: SolveArgs,
    /// Also run Monte Carlo, with N recorded samples in all (default 6e8: about 27 s on two
    /// idle cores, relative standard error under 3% in the 100 bins where the density exceeds
    /// 1e-4 of its peak for the bundled model).
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "6e8")]
    mc: Option<String>,
    #[command(flatten)]
    mc_args: McArgs,
}

#[derive(Args, Debug)]
struct SolveArgs {
    /// EPC degrees, comma-separated, solved in order with continuation.
    #[arg(
        long,
        value_name = "N,N,...",
        value_delimiter = ',',
        default_value = "2,4"
    )]
    degree: Vec<usize>,
    #[command(flatten)]
    set: SetArgs,
    /// Output directory (default: out/<model name>).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// No progress indication on stderr.
    #[arg(long)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct SetArgs {
    /// Override a parameter: `--set name=value`, the value an expression of numbers, `pi`,
    /// `e` and other parameters. May be repeated.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
}

#[derive(Args, Debug)]
struct McArgs {
    /// Monte Carlo time step.
    #[arg(long, default_value_t = 0.01)]
    dt: f64,
    /// Time between recorded samples.
    #[arg(long, default_value_t = 0.1)]
    spacing: f64,
    /// Seed of the random streams (a given seed gives bit-identical results).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Burn-in time before recording (default: 10 decay times of the linearised model).
    #[arg(long = "burn-in", value_name = "TIME")]
    burn_in: Option<f64>,
    /// Independent trajectories.
    #[arg(long, default_value_t = 4096)]
    trajectories: u64,
    /// Histogram grid of a state or observable: `--grid y=0:8:300` (lo:hi:bins). May be
    /// repeated; quantities without one get a grid from a short pilot run (or, in the main
    /// job, the EPC grid).
    #[arg(long = "grid", value_name = "NAME=LO:HI:BINS")]
    grid: Vec<String>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Read a model file, check it, and print it with its parameter values and its derived
    /// drift, diffusion and Fokker-Planck coefficients.
    Check {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        set: SetArgs,
    },
    /// Solve by EPC at the given degrees and write the states' marginal PDFs and summary.json.
    Solve {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        solve: SolveArgs,
    },
    /// Run the Monte Carlo simulation alone.
    Simulate {
        /// The model file (`.sde`).
        model: PathBuf,
        /// Recorded samples in all.
        #[arg(long, default_value = "2e8")]
        samples: String,
        #[command(flatten)]
        set: SetArgs,
        #[command(flatten)]
        mc_args: McArgs,
        /// Run only part K of N (`--shard 3/10`, K from 1) and write shard_K_of_N.json.
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// Output directory (default: out/<model name>).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
    /// Solve at every point of a parameter sweep in parallel: `--set eps=-0.3:0.3:13`
    /// (lo:hi:count), `--set mu=0.1,1` (a list), other `--set` fixed. Writes sweep.csv,
    /// sweep.json and figures of moments and tail probabilities.
    Sweep {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        set: SetArgs,
        /// The EPC degree solved at each point (continued from degree 2).
        #[arg(long, default_value_t = 4)]
        degree: usize,
        /// Output directory (default: out/<model name>_sweep).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Merge the shard files of `simulate --shard` found in the given directories.
    Merge {
        /// Directories holding shard_K_of_N.json files.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out/merged")]
        out: PathBuf,
    },
}

/// Exit status for a model or flag error (clap uses the same for usage errors).
const USAGE_ERROR: u8 = 2;
/// Exit status when the job ran but some EPC degree did not converge.
const PARTIAL_FAILURE: u8 = 1;

/// Why the command failed, with the exit status it maps to.
enum Failure {
    Usage(anyhow::Error),
    Partial(String),
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Usage(e)
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Partial(message)) => {
            eprintln!("{message}");
            ExitCode::from(PARTIAL_FAILURE)
        }
        Err(Failure::Usage(e)) => {
            // A closed stdout (`fpsolve check m.sde | head`) is not an error worth reporting.
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            let text = format!("{e:#}");
            let mut stderr = std::io::stderr().lock();
            let _ = if text.starts_with("error") {
                writeln!(stderr, "{text}")
            } else {
                writeln!(stderr, "error: {text}")
            };
            ExitCode::from(USAGE_ERROR)
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Some(Command::Check { model, set }) => Ok(check(&model, &set.set)?),
        Some(Command::Solve { model, solve }) => main_job(&model, &solve, None, Target::States),
        Some(Command::Simulate {
            model,
            samples,
            set,
            mc_args,
            shard,
            out,
        }) => Ok(simulate(
            &model,
            &samples,
            &set.set,
            &mc_args,
            shard.as_deref(),
            out,
        )?),
        Some(Command::Merge { dirs, out }) => Ok(merge(&dirs, &out)?),
        Some(Command::Sweep {
            model,
            set,
            degree,
            out,
            threads,
        }) => sweep(&model, &set.set, degree, out, threads),
        None => {
            let Some(model) = cli.run.model else {
                return Err(anyhow!(
                    "no model file given (try `fpsolve models/vibro_duffing.sde` or `fpsolve --help`)"
                )
                .into());
            };
            let mc = match &cli.run.mc {
                Some(n) => Some(mc_config(&cli.run.mc_args, n)?),
                None => None,
            };
            main_job(&model, &cli.run.solve, mc, Target::Observables)
        }
    }
}

/// Parses `name=value` into an [`Override`].
fn parse_override(arg: &str) -> Result<Override> {
    let Some((name, value)) = arg.split_once('=') else {
        bail!("`--set {arg}`: expected NAME=VALUE");
    };
    let name = name.trim();
    if name.is_empty() {
        bail!("`--set {arg}`: the parameter name is missing");
    }
    let value = parse_expr(value).map_err(|e| anyhow!("error: in `--set {arg}`\n{e}"))?;
    Ok(Override {
        name: name.to_string(),
        value,
    })
}

/// Loads a model and checks the overrides against it (so a bad `--set` fails before any work).
fn load(path: &Path, set: &[String]) -> Result<(Model, Vec<Override>)> {
    let overrides = set
        .iter()
        .map(|s| parse_override(s))
        .collect::<Result<Vec<_>>>()?;
    let model = load_model(path).map_err(|e| anyhow!("{e}"))?;
    model
        .bind(&overrides)
        .map_err(|e| anyhow!("error: {}: {e}", path.display()))?;
    Ok((model, overrides))
}

fn check(path: &Path, set: &[String]) -> Result<()> {
    let (model, overrides) = load(path, set)?;
    let bound = model.bind(&overrides).map_err(|e| anyhow!("error: {e}"))?;
    let mut out = std::io::stdout().lock();
    write!(out, "{model}").context("writing to stdout")?;
    writeln!(out, "\n# parameter values").context("writing to stdout")?;
    for (name, value) in bound.params() {
        writeln!(out, "#   {name} = {value}").context("writing to stdout")?;
    }
    let fpk = FpkOperator::derive(&bound).map_err(|e| anyhow!("error: {}: {e}", path.display()))?;
    writeln!(out, "\n# derived Fokker-Planck operator").context("writing to stdout")?;
    for line in fpk.to_string().lines() {
        writeln!(out, "# {line}").context("writing to stdout")?;
    }
    out.flush().context("writing to stdout")?;
    Ok(())
}

/// A count given as `200000000`, `2e8` or `2.5e6`.
fn parse_count(text: &str, what: &str) -> Result<u64> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| anyhow!("{what} `{text}` is not a number"))?;
    if !(v.is_finite() && (1.0..=1e15).contains(&v)) {
        bail!("{what} `{text}` must be between 1 and 1e15");
    }
    Ok(v.round() as u64)
}

fn mc_config(args: &McArgs, samples: &str) -> Result<McConfig> {
    let samples = parse_count(samples, "the number of Monte Carlo samples")?;
    set_threads(args.threads)?;
    if args.trajectories == 0 {
        bail!("--trajectories must be at least 1");
    }
    let per_trajectory = samples.div_ceil(args.trajectories).max(1);
    let mut grids = Vec::new();
    for g in &args.grid {
        let parsed = g.split_once('=').and_then(|(name, spec)| {
            let parts: Vec<&str> = spec.split(':').collect();
            let [lo, hi, bins] = parts.as_slice() else {
                return None;
            };
            Some((
                name.trim().to_string(),
                lo.trim().parse::<f64>().ok()?,
                hi.trim().parse::<f64>().ok()?,
                bins.trim().parse::<usize>().ok()?,
            ))
        });
        let Some((name, lo, hi, bins)) = parsed else {
            bail!("--grid `{g}`: expected NAME=LO:HI:BINS");
        };
        let grid = Grid::new(lo, hi, bins).map_err(|e| anyhow!("--grid `{g}`: {e}"))?;
        grids.push((name, grid));
    }
    Ok(McConfig {
        dt: args.dt,
        spacing: args.spacing,
        trajectories: args.trajectories,
        samples: per_trajectory,
        burn_in: match args.burn_in {
            Some(t) => BurnIn::Time(t),
            None => McConfig::default().burn_in,
        },
        seed: args.seed,
        grids,
        ..McConfig::default()
    })
}

fn default_out(out: Option<PathBuf>, model: &Model) -> PathBuf {
    out.unwrap_or_else(|| Path::new("out").join(model.name()))
}

/// Progress on stderr: a spinner per stage and a bar with ETA for Monte Carlo; silent when
/// stderr is not a terminal or with `--quiet`.
struct Bar(Option<indicatif::ProgressBar>);

impl Bar {
    fn new(quiet: bool) -> Bar {
        if quiet || !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        let bar = indicatif::ProgressBar::new_spinner();
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        Bar(Some(bar))
    }
    fn finish(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

impl Progress for Bar {
    fn stage(&self, message: &str) {
        if let Some(b) = &self.0 {
            b.set_style(indicatif::ProgressStyle::default_spinner());
            b.set_message(message.to_string());
        }
    }
    fn advance(&self, done: u64, total: u64) {
        if let Some(b) = &self.0 {
            if b.length() != Some(total) {
                b.set_length(total);
                if let Ok(style) = indicatif::ProgressStyle::with_template(
                    "{msg} [{bar:40}] {pos}/{len} parts, {elapsed} elapsed, ETA {eta}",
                ) {
                    b.set_style(style.progress_chars("=> "));
                }
            }
            b.set_position(done);
        }
    }
}

fn main_job(
    path: &Path,
    args: &SolveArgs,
    mc: Option<McConfig>,
    target: Target,
) -> Result<(), Failure> {
    let (model, overrides) = load(path, &args.set.set)?;
    if args.degree.is_empty() {
        return Err(anyhow!("--degree needs at least one degree").into());
    }
    let dir = default_out(args.out.clone(), &model);
    let out = OutputDir::create(&dir).map_err(|e| anyhow!("{e}"))?;
    let spec = JobSpec {
        degrees: args.degree.clone(),
        overrides,
        target,
        mc,
        mc_bins: 100,
        figures: target == Target::Observables,
    };
    let bar = Bar::new(args.quiet);
    let report = job::run(&model, &spec, &out, &bar);
    bar.finish();
    let report = report.map_err(|e| anyhow!("error: {}: {e}", path.display()))?;
    let mut stdout = std::io::stdout().lock();
    write!(stdout, "{}", job::table(&report)).context("writing to stdout")?;
    writeln!(
        stdout,
        "wrote {} files to {}",
        report.files.len(),
        dir.display()
    )
    .context("writing to stdout")?;
    let failed: Vec<String> = report
        .study
        .degrees
        .iter()
        .filter_map(|d| {
            d.outcome
                .as_ref()
                .err()
                .map(|e| format!("degree {}: {e}", d.degree))
        })
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Failure::Partial(format!(
            "error: EPC did not converge at some degrees (the others were written):\n  {}",
            failed.join("\n  ")
        )))
    }
}

fn simulate(
    path: &Path,
    samples: &str,
    set: &[String],
    args: &McArgs,
    shard: Option<&str>,
    out: Option<PathBuf>,
) -> Result<(), Failure> {
    let (model, overrides) = load(path, set)?;
    let bound = model.bind(&overrides).map_err(|e| anyhow!("{e}"))?;
    let config = mc_config(args, samples)?;
    // Everything is checked, and the cost estimated, before any trajectory runs.
    let estimate = config
        .estimate(&bound)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let shard = match shard {
        Some(spec) => {
            let part: Shard = spec.parse().map_err(|e| anyhow!("--shard: {e}"))?;
            if part.count > estimate.batches {
                return Err(anyhow!(
                    "--shard `{spec}`: at most {} shards (the run's statistics batches)",
                    estimate.batches
                )
                .into());
            }
            Some(part)
        }
        None => None,
    };
    estimate
        .within_limits(shard.map_or(1, |s| s.count))
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let sim = Simulation::new(&bound, &config).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let dir = default_out(out, &model);
    let out = OutputDir::create(&dir).map_err(|e| anyhow!("{e}"))?;
    match shard {
        Some(shard) => {
            let part = sim.run_shard(shard).map_err(|e| anyhow!("{e}"))?;
            let name = format!("shard_{}_of_{}.json", shard.index + 1, shard.count);
            let file = write_json(&out, &name, &part).map_err(|e| anyhow!("{e}"))?;
            println!("wrote {}", file.display());
            Ok(())
        }
        None => {
            let show = std::io::stderr().is_terminal() && estimate.seconds > 1.0;
            let start = std::time::Instant::now();
            let progress = |done: u64, total: u64| {
                if show {
                    let t = start.elapsed().as_secs_f64();
                    let eta = t / done as f64 * (total - done) as f64;
                    eprint!("\rMonte Carlo: {done}/{total} batches, {t:.0} s, ETA {eta:.0} s   ");
                }
            };
            let result = sim.run_with_progress(&progress);
            if show {
                eprintln!();
            }
            let result = result.map_err(|e| Failure::Partial(format!("error: {e}")))?;
            let files = job::write_mc(&result, &out).map_err(|e| anyhow!("{e}"))?;
            print!("{result}");
            println!("wrote {} files to {}", files.len(), dir.display());
            result.verdict().map_err(|e| {
                Failure::Partial(format!(
                    "error: {e} (the histograms were written to {}, flagged in mc_summary.json)",
                    dir.display()
                ))
            })
        }
    }
}

fn set_threads(threads: Option<usize>) -> Result<()> {
    if let Some(n) = threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting up the worker threads")?;
    }
    Ok(())
}

fn sweep(
    path: &Path,
    set: &[String],
    degree: usize,
    out: Option<PathBuf>,
    threads: Option<usize>,
) -> Result<(), Failure> {
    set_threads(threads)?;
    let model = load_model(path).map_err(|e| anyhow!("{e}"))?;
    let spec = SweepSpec::parse(set).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    spec.validate(&model)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let dir = out.unwrap_or_else(|| Path::new("out").join(format!("{}_sweep", model.name())));
    let out = OutputDir::create(&dir).map_err(|e| anyhow!("{e}"))?;
    let t = std::time::Instant::now();
    let result = Sweep::run(&model, &spec, degree);
    let files = result.write(&out).map_err(|e| anyhow!("{e}"))?;
    println!(
        "{} of {} points converged at degree {degree} in {:.1} s; wrote {} files to {}",
        result.converged(),
        spec.len(),
        t.elapsed().as_secs_f64(),
        files.len(),
        dir.display()
    );
    if result.converged() < spec.len() {
        return Err(Failure::Partial(format!(
            "error: {} points failed (reported in sweep.csv and sweep.json; the others were kept)",
            spec.len() - result.converged()
        )));
    }
    Ok(())
}

fn merge(dirs: &[PathBuf], out: &Path) -> Result<(), Failure> {
    let mut shards: Vec<(String, ShardOutput)> = Vec::new();
    for dir in dirs {
        let entries =
            std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))?;
        let mut names: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("shard_") && n.ends_with(".json"))
            })
            .collect();
        names.sort();
        for p in names {
            let text =
                std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
            let shard: ShardOutput = serde_json::from_str(&text)
                .with_context(|| format!("{} is not a shard file", p.display()))?;
            shards.push((p.display().to_string(), shard));
        }
    }
    if shards.is_empty() {
        return Err(anyhow!("no shard_*.json files in the given directories").into());
    }
    let result = merge_named(&shards).map_err(|e| anyhow!("{e}"))?;
    let out = OutputDir::create(out).map_err(|e| anyhow!("{e}"))?;
    let files = job::write_mc(&result, &out).map_err(|e| anyhow!("{e}"))?;
    print!("{result}");
    println!(
        "merged {} shards into {} files in {}",
        shards.len(),
        files.len(),
        out.path().display()
    );
    result.verdict().map_err(|e| {
        Failure::Partial(format!(
            "error: {e} (the merged histograms were written to {}, flagged in mc_summary.json)",
            out.path().display()
        ))
    })
}
