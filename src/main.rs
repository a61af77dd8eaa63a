//! `penumbra`: render a scene (or, with no arguments, the embedded default scene).

use clap::{Parser, Subcommand};
use penumbra::bench::{BenchArgs, run_bench};
use penumbra::merge::{MergeArgs, run_merge};
use penumbra::{RenderArgs, exit_cleanly_on_signals, run_render};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "penumbra",
    version,
    about = "Soft shadows from rectangular area lights, with pluggable shadow methods"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to PNG + EXR + a JSON run report.
    Render(RenderArgs),
    /// Shadow cost against error for every method and setting, against a cached traced truth:
    /// CSV, JSON, plots and an HTML report.
    Bench(BenchArgs),
    /// Assemble the tiles of `render --tile K/N` into the whole render's PNG, EXR, AOVs and
    /// report: the same bytes as rendering it at once.
    Merge(MergeArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // A bad value: clap's first line names the flag, the range and the value; the contract
        // gives bad input one line (and exit 2). Help, version and usage errors as clap prints
        // them (an unknown flag's line suggests the nearest one).
        Err(e) if e.kind() == clap::error::ErrorKind::ValueValidation => {
            let text = e.render().to_string();
            eprintln!("{}", text.lines().next().unwrap_or("error: bad value"));
            return ExitCode::from(2);
        }
        Err(e) => e.exit(),
    };
    exit_cleanly_on_signals();
    let args = match cli.command {
        Some(Command::Render(a)) => a,
        Some(Command::Bench(b)) => {
            return match run_bench(&b) {
                Ok(summary) => {
                    print!("{summary}");
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(2)
                }
            };
        }
        Some(Command::Merge(m)) => return merge(&m),
        None => RenderArgs::default(),
    };
    match run_render(&args) {
        Ok(outcome) => {
            // Warnings go to stderr always; --quiet silences only the progress and summary.
            for w in &outcome.report.warnings {
                eprintln!("warning: {w}");
            }
            if !args.quiet {
                print_summary(&outcome.report);
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// `penumbra render`'s summary on stdout: what was rendered, where the time went, what was
/// written.
fn print_summary(r: &penumbra::run_report::RunReport) {
    let t = &r.timings_s;
    // `none` casts no shadow rays: a sample count would say it does.
    let samples = if r.method == "none" { String::new() } else { format!(" ({} samples)", r.samples) };
    let kept =
        if r.kept_instances > 0 { format!(", {} kept unflattened", r.kept_instances) } else { String::new() };
    println!(
        "{}: {} {}x{} spp {}{samples}, max depth {}, {} triangles ({} unique, {} instances{kept}), \
             {} light(s), {} threads",
        r.scene,
        r.method,
        r.width,
        r.height,
        r.spp,
        r.max_depth,
        r.triangles,
        r.unique_triangles,
        r.instances,
        r.lights,
        r.threads
    );
    println!(
        "time: load {:.3}s, bvh {:.3}s, visible points {:.3}s, shadow_prepare {:.3}s, render {:.3}s, \
             write {:.3}s, total {:.3}s",
        t.load, t.bvh, t.visible_points, t.shadow_prepare, t.render, t.write, t.total
    );
    if let Some(t) = &r.tile {
        println!(
            "tile {} of {}: rows {}..{}; merge every tile with `penumbra merge`",
            t.index, t.count, t.rows[0], t.rows[1]
        );
    }
    println!("wrote {}", r.outputs.join(", "));
}

/// `penumbra merge`: warnings to stderr, a summary unless `--quiet`.
fn merge(args: &MergeArgs) -> ExitCode {
    match run_merge(args) {
        Ok(report) => {
            for w in &report.warnings {
                eprintln!("warning: {w}");
            }
            if !args.quiet {
                let tiles = report.tiles.as_ref().map_or(0, Vec::len);
                println!(
                    "{}: {} {}x{} from {tiles} tile(s), {:.3}s summed over the tiles and the merge",
                    report.scene, report.method, report.width, report.height, report.timings_s.total
                );
                println!("wrote {}", report.outputs.join(", "));
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
