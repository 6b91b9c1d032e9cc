//! The `envlight` command line. Each subcommand lives in its own file under `src/cli/`.

mod cli;

use clap::{Parser, Subcommand};
use cli::reports::{AccuracyWhat, Bench};
use cli::Global;

#[derive(Parser)]
#[command(
    name = "envlight",
    version,
    about = "Environment-map lighting on explicit Vulkan passes"
)]
struct Cli {
    #[command(flatten)]
    global: Global,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Info(cli::info::InfoArgs),
    Lights(cli::info::LightsArgs),
    Convert(cli::maps::ConvertArgs),
    Sh(cli::maps::ShArgs),
    Irradiance(cli::maps::IrradianceArgs),
    Prefilter(cli::maps::PrefilterArgs),
    /// What accuracy costs: SH irradiance of orders 0–8 against brute force, with GPU times
    Accuracy {
        #[command(subcommand)]
        what: AccuracyWhat,
    },
    Demo(cli::scene::DemoArgs),
    Render(cli::scene::RenderArgs),
    Plan(cli::scene::PlanArgs),
    /// List the Vulkan devices and the one envlight would pick
    Devices,
    SynthSky(cli::info::SynthSkyArgs),
    Report(cli::reports::report::ReportArgs),
    Bake(cli::bake::BakeArgs),
    /// Benchmarks (GPU time from timestamp queries)
    Bench {
        #[command(subcommand)]
        what: Bench,
    },
}

fn main() {
    // Output piped into a reader that stops early (`| head`) ends the process as other Unix
    // tools end, instead of making println! panic on EPIPE.
    #[cfg(unix)]
    // SAFETY: called first, before any thread exists; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let g = &cli.global;
    let result = match &cli.command {
        Command::Info(a) => cli::info::info(a),
        Command::Lights(a) => cli::info::lights(a),
        Command::Convert(a) => cli::maps::convert(g, a),
        Command::Sh(a) => cli::maps::sh(g, a),
        Command::Irradiance(a) => cli::maps::irradiance(g, a),
        Command::Prefilter(a) => cli::maps::prefilter(g, a),
        Command::Accuracy { what } => cli::reports::accuracy(g, what),
        Command::Demo(a) => cli::scene::demo(g, a),
        Command::Render(a) => cli::scene::render(g, a),
        Command::Plan(a) => cli::scene::plan(a),
        Command::Devices => cli::info::devices(g),
        Command::SynthSky(a) => cli::info::synth_sky(a),
        Command::Report(a) => cli::reports::report::report(g, a),
        Command::Bake(a) => cli::bake::bake(g, a),
        Command::Bench { what } => cli::reports::bench(g, what),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
    let messages = cli::validation_messages();
    if !messages.is_empty() {
        eprintln!(
            "error: the Vulkan validation layer reported {} message(s):\n{}",
            messages.len(),
            messages.join("\n")
        );
        std::process::exit(1);
    }
}
