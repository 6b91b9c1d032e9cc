//! `envlight-lab`: the project's own measurements, apart from the program users run. It
//! times envlight against the peers users pick instead (cmft, glTF-IBL-Sampler), writes the
//! recipe sweep, and keeps the performance pages of docs/performance/.
//! It uses the library's public API (with the float64 references of feature `reference`) and
//! runs the `envlight` program where a whole process is timed. Run it as `cargo xtask lab
//! COMMAND …`, which builds both; each module's doc names the page it writes.

mod accuracy;
mod common;
mod fis;
mod fis_report;
mod formats;
mod ibl;
mod own;
mod page;
mod peers;
mod previews;
mod recipes;
mod scale;

use clap::{Parser, Subcommand};
use common::Global;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "envlight-lab",
    about = "envlight's benchmarks against its peers, its recipe sweep and its performance pages"
)]
struct Lab {
    #[command(flatten)]
    global: Global,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// SH irradiance of orders 0–8 against brute force on maps or folders of maps, with GPU
    /// times (accuracy.md, accuracy.csv, accuracy.png)
    Accuracy {
        /// Maps, or folders whose .hdr/.exr/.dds/.pfm files are all taken
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output folder
        #[arg(long, default_value = "out/accuracy")]
        out: PathBuf,
        /// Cube face size of the set of normals compared
        #[arg(long, default_value_t = 8)]
        size: u32,
    },
    Fis(fis::FisArgs),
    Peers(peers::PeersArgs),
    Ibl(ibl::IblArgs),
    Scale(scale::ScaleArgs),
    Formats(formats::FormatsArgs),
    Recipes(recipes::RecipesArgs),
    Floors(own::FloorsArgs),
    Dynamic(own::DynamicArgs),
    /// The bake's previews: files against intent, right and broken, and their cost
    Previews(previews::PreviewsArgs),
}

fn main() {
    let lab = Lab::parse();
    let g = &lab.global;
    let result = match &lab.command {
        Command::Accuracy { inputs, out, size } => accuracy::accuracy_sh(g, inputs, out, *size),
        Command::Fis(a) => fis::bench_fis(g, a),
        Command::Peers(a) => peers::cli(g, a),
        Command::Ibl(a) => ibl::run(g, a),
        Command::Scale(a) => scale::bench_scale(g, &a.input, &a.factors, a.out.as_ref()),
        Command::Formats(a) => formats::run(g, a),
        Command::Recipes(a) => recipes::run(g, a),
        Command::Floors(a) => own::floors(g, a),
        Command::Dynamic(a) => own::dynamic(g, a),
        Command::Previews(a) => previews::run(g, a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
    let messages = common::validation_messages();
    if !messages.is_empty() {
        eprintln!(
            "error: the Vulkan validation layer reported {} message(s):\n{}",
            messages.len(),
            messages.join("\n")
        );
        std::process::exit(1);
    }
}
