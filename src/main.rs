//! The `fpsolve` command line: argument parsing and calls into the library, nothing more.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use fpsolve::base::input_file::{read_regular_text, MAX_RESULT_FILE_BYTES};
use fpsolve::epc::DegreeList;
use fpsolve::grid::Cells;
use fpsolve::job::{self, JobSpec, Progress, Target};
use fpsolve::mc::{merge_named, McConfig, McResult, Shard, ShardOutput, Simulation};
use fpsolve::model::{load_model, BoundModel, Model, Override};
use fpsolve::report::{write_json, OutputDir, RunDir};
use fpsolve::solve::{MethodName, MethodSet, Problem};
use fpsolve::sweep::{Sweep, SweepSpec};

mod cli;
use cli::console::{say, sayln, Console};
use cli::job_plan::plan_job;
#[cfg(test)]
use cli::mc_flags::parse_count;
use cli::mc_flags::McFlags;
use cli::progress::Bar;
use cli::{allocator, sweep_flags};

/// Stationary PDFs of randomly excited nonlinear oscillators.
///
/// `fpsolve MODEL` runs the main job: EPC at degrees 2 and 4 and the grid solver, the PDFs of
/// every observable, a table, CSV files, summary.json and figures in out/<model>/.
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
    /// Compare with a finished Monte Carlo run instead of running one: the output directory
    /// of `fpsolve simulate` or `fpsolve merge` (same model and parameters; its histogram
    /// grids are the comparison bins).
    #[arg(long = "mc-from", value_name = "DIR", conflicts_with = "mc")]
    mc_from: Option<PathBuf>,
    #[command(flatten)]
    mc_args: McArgs,
}

#[derive(Args, Debug)]
struct SolveArgs {
    /// EPC degrees: even, distinct, 2 to 12, comma-separated. Every even degree up to the
    /// largest is solved in turn (continuation), so a degree's answer does not depend on the
    /// others asked.
    #[arg(long, value_name = "N,N,...", default_value = "2,4")]
    degree: DegreeList,
    /// Methods, comma-separated: `epc` (the paper's closure, δ-term impacts), `epc-impact`
    /// (EPC with the exact impact condition), `grid` (finite volumes, impacts exact). Default
    /// for the main job: epc,grid, with epc-impact where EPC cannot use the impact law, each
    /// where it applies; for `solve`: epc. Methods named here that do not apply to the model
    /// are refused, all of them in one message.
    #[arg(long, value_name = "NAME,...")]
    method: Option<MethodSet>,
    /// Cells of the grid solver, position and velocity: even, at least 8 each (without
    /// --cells or --tol the grid is solved to the tolerance 1e-3).
    #[arg(long, value_name = "NX,NV")]
    cells: Option<Cells>,
    /// The grid solver's box instead of one sized from the density: `x=LO:HI,v=LO:HI` (or
    /// the model's state names), the velocity's range around 0 (made symmetric); a reflecting
    /// wall's side must end on the wall. A box that cuts the density is flagged (its edge
    /// mass is reported and counted in the error estimate).
    #[arg(long, value_name = "x=LO:HI,v=LO:HI", allow_hyphen_values = true)]
    domain: Option<String>,
    /// The grid solver's accuracy instead of its cells: it chooses and refines them until
    /// its estimated L1 error of both marginals is at most L1 (0 < L1 <= 0.5; not with
    /// --cells; default 1e-3 without --cells). Not reached: the best solve is written and
    /// the run exits 1.
    #[arg(long, value_name = "L1", allow_hyphen_values = true)]
    tol: Option<f64>,
    #[command(flatten)]
    set: SetArgs,
    /// Output directory (default: out/<model name>).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    #[command(flatten)]
    quiet: QuietArg,
}

#[derive(Args, Debug)]
struct QuietArg {
    /// No progress display on stderr (notes, warnings and errors are still printed).
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
        #[command(flatten)]
        quiet: QuietArg,
    },
    /// Solve by EPC at the given degrees and write the states' marginal PDFs, their crossing rates and summary.json.
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
        /// Output directory (default: out/<model name>). Replaced as a whole by the run, except
        /// with `--shard`, where each shard adds its own file.
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        #[command(flatten)]
        quiet: QuietArg,
    },
    /// Solve at every point of a parameter sweep in parallel, by each method asked
    /// (`--method epc,grid`): `--set eps=-0.3:0.3:13` (lo:hi:count), `--set mu=0.1,1` (a
    /// list), other `--set` fixed. Writes sweep.csv, sweep.json and figures of moments and
    /// tail probabilities, one column set and one curve per method.
    Sweep {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        set: SetArgs,
        /// The EPC degree solved at each point (continued from degree 2): one even degree.
        #[arg(long, default_value = "4")]
        degree: DegreeList,
        /// The methods each point is solved by: any of epc, epc-impact, grid,
        /// comma-separated; each gets its own columns and curves.
        #[arg(long, value_name = "M,M,...", default_value = "epc")]
        method: MethodSet,
        /// Cells of the grid method, position and velocity: even, at least 8 (default
        /// 200,400).
        #[arg(long, value_name = "NX,NV")]
        cells: Option<Cells>,
        /// The grid's box at every point, as `solve --domain` takes it: `x=LO:HI,v=LO:HI`
        /// (the model's state names), checked against the walls at every point.
        #[arg(long, value_name = "x=LO:HI,v=LO:HI", allow_hyphen_values = true)]
        domain: Option<String>,
        /// Output directory (default: out/<model name>_sweep).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        #[command(flatten)]
        shard: sweep_flags::SweepShardArg,
        #[command(flatten)]
        quiet: QuietArg,
    },
    /// Reliability: first passage out of the model's safe set (or --safe) on the grid and by
    /// Monte Carlo: the mean time and its second moment from --start and from the stationary
    /// density in the set, and R(t) with the first-passage-time density at --times. Writes
    /// reliability.csv, first_passage_pdf.csv, figures and summary.json. `passage` is the same
    /// command under its former name.
    #[command(visible_alias = "passage")]
    Reliability {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        args: cli::reliability::ReliabilityArgs,
        #[command(flatten)]
        quiet: QuietArg,
    },
    /// The density as it evolves in time on the grid, from the model's `initial` line (or
    /// --initial; rest without either) to --times. Writes moments_vs_t.csv,
    /// pdf_<state>_t.csv and summary.json.
    Transient {
        /// The model file (`.sde`).
        model: PathBuf,
        #[command(flatten)]
        args: cli::transient::TransientArgs,
        #[command(flatten)]
        quiet: QuietArg,
    },
    /// Merge the shard files of `simulate --shard` (or of `sweep --shard`) found in the given
    /// directories.
    Merge {
        /// Directories holding shard_K_of_N.json (or sweep_shard_K_of_N.json) files.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out/merged")]
        out: PathBuf,
        #[command(flatten)]
        quiet: QuietArg,
    },
}

/// Exit status for a model or flag error: nothing was computed or written.
const USAGE_ERROR: u8 = 2;
/// Exit status when the run finished and wrote its files, but something in them is flagged
/// (a degree that did not converge, an undefined number, a Monte Carlo verdict).
const FLAGGED: u8 = 1;
/// Exit status after SIGINT/SIGTERM (128 + SIGINT): the unfinished output was removed.
const INTERRUPTED: i32 = 130;

/// Why the command did not succeed, with the exit status it maps to.
enum Failure {
    /// Bad input or flags, found before any computation: exit 2.
    Usage(anyhow::Error),
    /// The run finished and wrote everything; what is flagged: exit 1.
    Flagged(String),
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Usage(e)
    }
}

fn main() -> ExitCode {
    fpsolve::base::timeline::mark("main");
    allocator::keep_freed_memory();
    // An interrupted run removes its staging directory: the previous results stay as they
    // were and no partial file is left behind.
    // The handler says what it did: it and a commit take one lock, so the sentence is true
    // whether the signal came before, during or after the commit.
    let _ = ctrlc::set_handler(|| {
        let abandoned = fpsolve::report::abandon_unfinished();
        let _ = writeln!(std::io::stderr(), "\ninterrupted: {abandoned}");
        std::process::exit(INTERRUPTED);
    });
    fpsolve::report::set_command(std::env::args_os().map(|a| a.to_string_lossy().into_owned()));
    let cli = Cli::parse();
    let status = run(cli);
    fpsolve::base::timeline::mark("end");
    fpsolve::base::timeline::print();
    match status {
        // Reported once when it happened; the files are written.
        Ok(()) if Console::state() == Console::Failed => ExitCode::from(FLAGGED),
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Flagged(message)) => {
            eprintln!("{message}");
            ExitCode::from(FLAGGED)
        }
        Err(Failure::Usage(e)) => {
            // A closed stdout (`fpsolve check m.sde | head`) is not an error worth reporting.
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            let text = render(&e);
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

/// A library error as it flows out of a command, its source chain kept.
fn lib<E: Into<fpsolve::Error>>(e: E) -> anyhow::Error {
    anyhow::Error::new(e.into())
}

/// A library error about `path` (the model file): `path: error`.
fn at<E: Into<fpsolve::Error>>(path: &Path) -> impl FnOnce(E) -> anyhow::Error + '_ {
    move |e| lib(e).context(path.display().to_string())
}

/// A library error about `path` whose message is a diagnostic of its own: `error: path: error`.
fn at_error<E: Into<fpsolve::Error>>(path: &Path) -> impl FnOnce(E) -> anyhow::Error + '_ {
    move |e| lib(e).context(format!("error: {}", path.display()))
}

/// An error about a flag: `--flag: error`.
fn flag<E: std::error::Error + Send + Sync + 'static>(
    name: &'static str,
) -> impl FnOnce(E) -> anyhow::Error {
    move |e| anyhow::Error::new(e).context(name)
}

/// The message of an error and its causes, each cause added only when the message does not
/// already say it (the library's messages quote their cause where a reader needs it).
fn render(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if text.contains(&s) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&s);
    }
    text
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.downcast_ref::<std::io::Error>()
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

fn run(cli: Cli) -> Result<(), Failure> {
    fpsolve::base::simd::check_env().map_err(|e| Failure::Usage(anyhow::anyhow!(e)))?;
    if solves_on_global_pool(&cli) {
        // The global pool's start (its threads spawned, the cores counted: 0.4–0.8 ms here)
        // on a thread of its own, beside the reading and checking of the plan, rather than
        // on the main thread after it. A plan that is refused leaves it idle; a plan that
        // uses rayon waits for it as it would have started it.
        std::thread::spawn(|| rayon::spawn(|| ()));
    }
    let planned = plan(cli)?;
    fpsolve::base::timeline::mark("planned");
    for n in &planned.notes {
        eprintln!("note: {n}");
    }
    match planned.threads {
        // A pool of our own, not the global one: checking the plan may already have used
        // rayon (which starts the global pool), and `build_global` then fails.
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("setting up the worker threads")?
            .install(|| execute(planned.plan)),
        None => execute(planned.plan),
    }
}

/// Whether `cli` runs the main job, `solve` or `sweep` on the global pool (no `--threads`):
/// the commands whose first parallel loop comes milliseconds after the start.
fn solves_on_global_pool(cli: &Cli) -> bool {
    match &cli.command {
        Some(Command::Solve { .. }) => true,
        Some(Command::Sweep { threads, .. }) => threads.is_none(),
        None => cli.run.mc.is_none() || cli.run.mc_args.threads.is_none(),
        _ => false,
    }
}

/// A command with every input read and checked: what [`execute`] runs. Making a plan reads
/// the model file and the flags and checks them (milliseconds), computes nothing and writes
/// nothing.
enum Plan {
    Check {
        path: PathBuf,
        model: Model,
        bound: BoundModel,
    },
    Job {
        path: PathBuf,
        model: Model,
        /// The model bound and its problem derived, as checked.
        problem: Box<Problem<'static>>,
        spec: JobSpec,
        out: PathBuf,
        quiet: bool,
    },
    Simulate {
        path: PathBuf,
        dynamics: Box<fpsolve::dynamics::Dynamics>,
        config: McConfig,
        shard: Option<Shard>,
        out: PathBuf,
        quiet: bool,
    },
    Sweep {
        model: Model,
        spec: SweepSpec,
        degree: usize,
        methods: MethodSet,
        cells: Cells,
        domain: Option<fpsolve::grid::Domain>,
        shard: Option<Shard>,
        out: PathBuf,
        quiet: bool,
    },
    MergeSweep(Box<fpsolve::sweep::MergedSweep>, PathBuf),
    Reliability(Box<cli::reliability::ReliabilityPlan>),
    Transient(Box<cli::transient::TransientPlan>),
    Merge {
        result: Box<McResult>,
        /// The parts' `provenance` blocks (the model, the threads they ran with).
        parts: Vec<Option<serde_json::Value>>,
        out: PathBuf,
    },
}

/// A plan with what every command shares: notes on values that were adjusted (rounded,
/// capped), and the worker threads.
struct Planned {
    plan: Plan,
    notes: Vec<String>,
    threads: Option<usize>,
}

/// Reads and checks everything a command needs, before any computation.
fn plan(cli: Cli) -> Result<Planned> {
    let mut notes = Vec::new();
    let mut threads = None;
    let plan = match cli.command {
        Some(Command::Check { model, set, .. }) => {
            let (m, _, bound) = load(&model, &set.set)?;
            Plan::Check {
                path: model,
                model: m,
                bound,
            }
        }
        Some(Command::Reliability { model, args, .. }) => {
            Plan::Reliability(Box::new(cli::reliability::plan(model, args)?))
        }
        Some(Command::Transient { model, args, .. }) => {
            Plan::Transient(Box::new(cli::transient::plan(model, args)?))
        }
        Some(Command::Solve { model, solve }) => {
            plan_job(model, &solve, None, None, Target::States)?
        }
        Some(Command::Simulate {
            model,
            samples,
            set,
            mc_args,
            shard,
            out,
            quiet,
        }) => {
            let (m, _, bound) = load(&model, &set.set)?;
            let flags = McFlags::parse(&mc_args, &samples, "--samples")?;
            // Settings checked and the cost estimated; the limits apply to what this process
            // runs (one shard of N on a cluster).
            let dynamics = Box::new(fpsolve::dynamics::Dynamics::read(&bound));
            let estimate = flags.config.estimate_of(&dynamics).map_err(at(&model))?;
            let shard: Option<Shard> = match shard.as_deref() {
                Some(spec) => {
                    let part: Shard = spec
                        .parse()
                        .map_err(|e| anyhow::Error::new(e).context(format!("--shard `{spec}`")))?;
                    if part.count > estimate.batches {
                        bail!(
                            "--shard `{spec}`: at most {} shards (the run's statistics batches)",
                            estimate.batches
                        );
                    }
                    Some(part)
                }
                None => None,
            };
            estimate
                .within_limits(shard.map_or(1, |s| s.count))
                .map_err(at(&model))?;
            notes = flags.notes;
            threads = check_threads(mc_args.threads, &mut notes)?;
            Plan::Simulate {
                out: default_out(out, &m),
                path: model,
                dynamics,
                config: flags.config,
                shard,
                quiet: quiet.quiet,
            }
        }
        Some(Command::Merge { dirs, out, .. }) => {
            dirs.iter().for_each(|d| read_input(d));
            if let Some(shards) = sweep_flags::read_sweep_shards(&dirs)? {
                let merged = sweep_flags::merge(&shards)?;
                return Ok(Planned {
                    plan: Plan::MergeSweep(Box::new(merged), out),
                    notes,
                    threads,
                });
            }
            let shards = read_shards(&dirs)?;
            // Every shard is validated (and named when it is not right) before anything is
            // written.
            let result = merge_named(&shards).map_err(lib)?;
            Plan::Merge {
                result: Box::new(result),
                parts: shards.into_iter().map(|(_, s)| s.provenance).collect(),
                out,
            }
        }
        Some(Command::Sweep {
            model,
            set,
            degree,
            method,
            cells,
            domain,
            out,
            threads: t,
            shard,
            quiet,
        }) => {
            let [d] = degree.as_slice() else {
                bail!("--degree {degree}: a sweep solves one degree at each point");
            };
            if cells.is_some() && !method.contains(MethodName::Grid) {
                bail!(
                    "--cells applies to the grid method, which --method {method} does not ask for"
                );
            }
            let cells = cells.unwrap_or_default();
            read_input(&model);
            let m = load_model(&model).map_err(lib)?;
            let spec = SweepSpec::parse(&set.set).map_err(at(&model))?;
            spec.validate(&m).map_err(at(&model))?;
            let domain = cli::domain_flag::sweep_domain(domain.as_deref(), &method, &m)?;
            // A method that does not apply to the model is refused before any work.
            with_domain(Sweep::new(&m, &spec), domain)
                .methods(method.clone())
                .degree(*d)
                .cells(cells)
                .check()
                .map_err(at(&model))?;
            threads = check_threads(t, &mut notes)?;
            if method.contains(MethodName::Grid) {
                // The points solved at once each hold their own factorisation.
                let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
                let at_once = threads.unwrap_or(cores).min(spec.len());
                cells
                    .within_at_once(fpsolve::base::limits::memory_limit_bytes(), at_once)
                    .with_context(|| format!("--cells {cells} with {at_once} sweep points solved at once (--threads)"))?;
            }
            let shard = shard.parse(spec.len())?;
            Plan::Sweep {
                shard,
                out: out.unwrap_or_else(|| Path::new("out").join(format!("{}_sweep", m.name()))),
                model: m,
                spec,
                degree: *d,
                methods: method,
                cells,
                domain,
                quiet: quiet.quiet,
            }
        }
        None => {
            let Some(model) = cli.run.model else {
                bail!("no model file given (try `fpsolve models/vibro_duffing.sde` or `fpsolve --help`)");
            };
            let mc = match &cli.run.mc {
                Some(n) => {
                    let flags = McFlags::parse(&cli.run.mc_args, n, "--mc")?;
                    notes = flags.notes;
                    threads = check_threads(cli.run.mc_args.threads, &mut notes)?;
                    Some(flags.config)
                }
                None => None,
            };
            plan_job(
                model,
                &cli.run.solve,
                mc,
                cli.run.mc_from.as_deref(),
                Target::Observables,
            )?
        }
    };
    Ok(Planned {
        plan,
        notes,
        threads,
    })
}

/// Runs a checked plan: the output directory is taken (locked, staged) first, then the work.
fn execute(plan: Plan) -> Result<(), Failure> {
    match plan {
        Plan::Check { path, model, bound } => Ok(check(&path, &model, &bound)?),
        Plan::Job {
            path,
            model,
            problem,
            spec,
            out,
            quiet,
        } => main_job(&path, &model, &problem, &spec, &out, quiet),
        Plan::Simulate {
            path,
            dynamics,
            config,
            shard,
            out,
            quiet,
        } => simulate(&path, &dynamics, &config, shard, &out, quiet),
        Plan::Sweep {
            model,
            spec,
            degree,
            methods,
            cells,
            domain,
            shard,
            out,
            quiet,
        } => {
            let sweep = with_domain(Sweep::new(&model, &spec), domain)
                .methods(methods)
                .degree(degree)
                .cells(cells);
            match shard {
                Some(shard) => sweep_flags::run_shard(sweep, shard, &out, quiet),
                None => sweep_flags::run_whole(sweep, &spec, degree, &out, quiet),
            }
        }
        Plan::MergeSweep(merged, out) => sweep_flags::write_merged(&merged, &out),
        Plan::Reliability(plan) => Ok(cli::reliability::run(*plan)?),
        Plan::Transient(plan) => {
            let flags = cli::transient::run(*plan)?;
            if flags.is_empty() {
                Ok(())
            } else {
                Err(Failure::Flagged(format!(
                    "error: the run finished and its files were written, but:\n  {}",
                    flags.join("\n  ")
                )))
            }
        }
        Plan::Merge { result, parts, out } => merge(&result, &parts, &out),
    }
}

/// Loads a model and binds it with the overrides (so a bad `--set` fails before any work).
fn load(path: &Path, set: &[String]) -> Result<(Model, Vec<Override>, BoundModel)> {
    let overrides = set
        .iter()
        .map(|s| s.parse::<Override>().map_err(lib))
        .collect::<Result<Vec<_>>>()?;
    read_input(path);
    let model = load_model(path).map_err(lib)?;
    let bound = model.bind(&overrides).map_err(at_error(path))?;
    Ok((model, overrides, bound))
}

/// [`load`], with the model amended before it is bound (a `--safe` or `--initial` line given
/// on the command line), so that the bound model is the amended one.
fn load_amended(
    path: &Path,
    set: &[String],
    amend: impl FnOnce(Model) -> Result<Model>,
) -> Result<(Model, BoundModel)> {
    let (model, overrides, _) = load(path, set)?;
    let model = amend(model)?;
    let bound = model.bind(&overrides).map_err(at_error(path))?;
    Ok((model, bound))
}

fn check(path: &Path, model: &Model, bound: &BoundModel) -> Result<()> {
    let text = fpsolve::check::render(model, bound).map_err(at_error(path))?;
    say!("{text}");
    Ok(())
}

fn default_out(out: Option<PathBuf>, model: &Model) -> PathBuf {
    out.unwrap_or_else(|| Path::new("out").join(model.name()))
}

/// The command line as run, recorded in the output directory's marker file (an argument
/// that is not UTF-8 is recorded with U+FFFD in place of its bad bytes).
fn command_line() -> String {
    std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// The files and directories this command reads, noted as they are read: an output
/// directory that is or holds one of them is refused.
static INPUTS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Notes `path` as an input of this command (see [`INPUTS`]).
fn read_input(path: &Path) {
    INPUTS
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .push(path.to_path_buf());
}

/// Locks and stages the output directory: a usage error (before any computation) when it is
/// taken by another run, holds other files or an input of this command, or cannot be
/// created.
fn begin_output(dir: &Path) -> Result<RunDir> {
    let inputs = INPUTS.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    RunDir::begin_reading(dir, &command_line(), &inputs).map_err(flag("--out"))
}

/// Puts a finished run's files in place and says where.
fn commit_output(run: RunDir, files: usize) -> Result<()> {
    let dest = run.commit().map_err(lib)?;
    sayln!("wrote {files} files to {}", dest.display());
    Ok(())
}

fn main_job(
    path: &Path,
    model: &Model,
    problem: &Problem,
    spec: &JobSpec,
    out: &Path,
    quiet: bool,
) -> Result<(), Failure> {
    let run = begin_output(out)?;
    fpsolve::base::timeline::mark("output begun");
    let bar = Bar::new(quiet);
    let report = job::Job::new(model, spec)
        .problem(problem)
        .progress(&bar)
        .run(run.out());
    bar.finish();
    let report = report.map_err(at_error(path))?;
    say!("{report}");
    // A warning that does not flag the run is said on stderr too (those that do are said
    // with the flags).
    for w in report.study.warnings.iter().filter(|w| !w.flags()) {
        eprintln!("warning: {w}");
    }
    fpsolve::base::timeline::mark("report printed");
    commit_output(run, report.files.len())?;
    let flagged = job::flags(&report);
    if flagged.is_empty() {
        Ok(())
    } else {
        Err(Failure::Flagged(format!(
            "error: the run finished and its files were written, but:\n  {}",
            flagged.join("\n  ")
        )))
    }
}

fn simulate(
    path: &Path,
    dynamics: &fpsolve::dynamics::Dynamics,
    config: &McConfig,
    shard: Option<Shard>,
    dir: &Path,
    quiet: bool,
) -> Result<(), Failure> {
    match shard {
        Some(shard) => {
            // Shards of one run share a directory: each adds its own file, atomically.
            let out = OutputDir::create(dir).map_err(flag("--out"))?;
            let sim = Simulation::reading(dynamics, config).map_err(at(path))?;
            let part = sim.run_shard(shard).map_err(lib)?;
            let name = format!("shard_{}_of_{}.json", shard.index + 1, shard.count);
            let file = write_json(&out, &name, &part).map_err(lib)?;
            sayln!("wrote {}", file.display());
            Ok(())
        }
        None => {
            let run = begin_output(dir)?;
            let sim = Simulation::reading(dynamics, config).map_err(at(path))?;
            let bar = Bar::new(quiet);
            bar.stage("Monte Carlo");
            let result = sim.run_with_progress(&|done, total| bar.advance(done, total));
            bar.finish();
            // The run computed but has no result to write (every trajectory blew up, say).
            let result = result.map_err(|e| {
                Failure::Flagged(format!("error: {}: Monte Carlo: {e}", path.display()))
            })?;
            let provenance = fpsolve::report::Provenance::now_bound(dynamics.model());
            let written = job::write_mc(&result, &provenance, run.out()).map_err(lib)?;
            say!("{result}");
            commit_output(run, written.files.len())?;
            verdict(&result, &written)
        }
    }
}

/// Checks `--threads`; more than the machine's cores are capped (results do not depend on
/// the number of threads, only the time does), with a note.
fn check_threads(threads: Option<usize>, notes: &mut Vec<String>) -> Result<Option<usize>> {
    let Some(n) = threads else {
        return Ok(None);
    };
    if n == 0 {
        bail!("--threads must be at least 1");
    }
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    if n > cores {
        notes.push(format!(
            "--threads {n} capped at the {cores} cores available"
        ));
        return Ok(Some(cores));
    }
    Ok(Some(n))
}

/// Reads every `shard_*.json` in `dirs`.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<(String, ShardOutput)>> {
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
            let text = read_regular_text(&p, MAX_RESULT_FILE_BYTES)
                .with_context(|| format!("reading {}", p.display()))?;
            let shard: ShardOutput = serde_json::from_str(&text)
                .with_context(|| format!("{} is not a shard file", p.display()))?;
            shards.push((p.display().to_string(), shard));
        }
    }
    if shards.is_empty() {
        bail!("no shard_*.json files in the given directories");
    }
    Ok(shards)
}

/// Writes a merged Monte Carlo run, with the merge's provenance: its command and time, the
/// model and threads of the `parts` (their `provenance` blocks).
fn merge(
    result: &McResult,
    parts: &[Option<serde_json::Value>],
    out: &Path,
) -> Result<(), Failure> {
    let run = begin_output(out)?;
    let provenance = fpsolve::report::Provenance::merged(parts.iter().map(Option::as_ref));
    let written = job::write_mc(result, &provenance, run.out()).map_err(lib)?;
    say!("{result}");
    sayln!("merged {} shards", parts.len());
    commit_output(run, written.files.len())?;
    verdict(result, &written)
}

/// A finished Monte Carlo result whose verdict failed (blow-ups, not stationary) or with
/// numbers that have no finite value was written, flagged: exit 1 with the reasons.
fn verdict(result: &McResult, written: &job::McFiles) -> Result<(), Failure> {
    let flagged = written.flags(result);
    if flagged.is_empty() {
        return Ok(());
    }
    Err(Failure::Flagged(format!(
        "error: the Monte Carlo run finished and its files were written, flagged in mc_summary.json, but:\n  {}",
        flagged.join("\n  ")
    )))
}

/// The sweep with the grid's box `--domain` when given.
fn with_domain(sweep: Sweep<'_>, domain: Option<fpsolve::grid::Domain>) -> Sweep<'_> {
    match domain {
        Some(d) => sweep.grid_domain(d),
        None => sweep,
    }
}
