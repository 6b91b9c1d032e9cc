//! `envlight info`, `lights` and `devices`.

use super::{context, load_input, Global, Input};
use crate::math::lights::{extract, group, ExtractOptions};
use crate::EnvMap;
use anyhow::Result;
use clap::Args;

/// Print a map's mapping, size, radiance statistics and total power
#[derive(Args)]
pub struct InfoArgs {
    #[command(flatten)]
    input: Input,
}

/// List a map's compact bright sources (light extraction): direction, solid angle, power and
/// share of the total
#[derive(Args)]
pub struct LightsArgs {
    #[command(flatten)]
    input: Input,
    /// A texel is a light texel above this many times the map's mean luminance
    #[arg(long, default_value_t = crate::abi::lights::DEFAULT_RATIO)]
    ratio: f64,
    /// Most light texels kept (the threshold rises to keep to it)
    #[arg(long, default_value_t = crate::abi::lights::MAX_TEXELS as usize)]
    max_texels: usize,
    /// Grow the lights by this many rings of texels and fill the residual under them from
    /// around them, as the renderer's chain does (default: clamp the residual at the
    /// threshold)
    #[arg(long)]
    fill: Option<u32>,
    /// Print JSON instead of a table
    #[arg(long)]
    json: bool,
}

/// Texels within this angle (radians) of a light's first texel are reported as that light.
const GROUP_RADIUS: f64 = 0.1;

fn print_lights(map: &EnvMap, opts: &ExtractOptions) {
    let ex = extract(map, opts);
    let lights = group(map, &ex, GROUP_RADIUS);
    let share: f64 = lights.iter().map(|l| l.share).sum();
    let mean = crate::math::envmap::luminance(map.stats().power) / (4.0 * std::f64::consts::PI);
    println!(
        "lights:    {} ({} texels above {:.4e} = {:.1} x the mean luminance{}{}; {:.1}% of the power)",
        lights.len(),
        ex.lights.len(),
        ex.threshold,
        ex.threshold / mean,
        if ex.threshold > opts.ratio * mean * (1.0 + 1e-12) {
            format!(", raised from {} x to keep at most {} texels", opts.ratio, opts.max_texels)
        } else {
            String::new()
        },
        match opts.fill {
            Some(d) => format!(
                ", grown by up to {d} rings of texels where the cap leaves room, the residual \
                 under them filled from around them"
            ),
            None => String::new(),
        },
        100.0 * share
    );
    for (k, l) in lights.iter().enumerate() {
        println!(
            "  {k}: direction [{:+.4}, {:+.4}, {:+.4}], {:.3e} sr, power [{:.4e}, {:.4e}, {:.4e}], \
             {:.2}% of the total, {} texels",
            l.direction[0],
            l.direction[1],
            l.direction[2],
            l.solid_angle,
            l.power[0],
            l.power[1],
            l.power[2],
            100.0 * l.share,
            l.texels
        );
    }
}

/// `envlight lights`.
pub fn lights(a: &LightsArgs) -> Result<()> {
    if !(a.ratio.is_finite() && a.ratio > 0.0) {
        anyhow::bail!("--ratio {}: must be positive and finite", a.ratio);
    }
    let map = load_input(&a.input)?;
    let opts = ExtractOptions {
        ratio: a.ratio,
        max_texels: a.max_texels,
        fill: a.fill,
    };
    if a.json {
        let ex = extract(&map, &opts);
        let report = serde_json::json!({
            "file": a.input.input,
            "threshold": ex.threshold,
            "options": opts,
            "light_texels": ex.lights.len(),
            "lights": group(&map, &ex, GROUP_RADIUS),
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("file:      {}", a.input.input);
        print_lights(&map, &opts);
    }
    Ok(())
}

/// `envlight info`.
pub fn info(a: &InfoArgs) -> Result<()> {
    let map = load_input(&a.input)?;
    let s = map.stats();
    println!("file:      {}", a.input.input);
    println!("mapping:   {}", map.mapping.name());
    println!(
        "size:      {} x {} x {} layer(s)",
        map.width,
        map.height,
        map.layers()
    );
    println!("channels:  RGB (linear float)");
    println!("min:       {:?}", s.min);
    println!(
        "max:       {:?}  (max luminance {:.6e})",
        s.max, s.max_luminance
    );
    println!(
        "mean:      [{:.6e}, {:.6e}, {:.6e}]  (solid-angle weighted)",
        s.mean[0], s.mean[1], s.mean[2]
    );
    println!("nan:       {}", s.nan);
    println!("inf:       {}", s.inf);
    println!("negative:  {}", s.negative);
    println!(
        "power:     [{:.6e}, {:.6e}, {:.6e}]  (sum of L * solid angle, W/m^2 per unit radiance)",
        s.power[0], s.power[1], s.power[2]
    );
    print_lights(&map, &ExtractOptions::default());
    Ok(())
}

/// `envlight devices`.
pub fn devices(g: &Global) -> Result<()> {
    let ctx = context(g)?;
    let i = ctx.info();
    println!(
        "envlight uses: {} ({:?}), driver {}",
        i.name, i.device_type, i.driver
    );
    // What `--device` takes to pin this device (on NVIDIA, as `nvidia-smi -L` prints it).
    println!("UUID {}", crate::gpu::uuid_text(&i.uuid));
    println!(
        "timestamp period {} ns, {} valid bits",
        i.timestamp_period, i.timestamp_valid_bits
    );
    let startup = ctx.startup();
    // Destroying the device and instance is the driver's too: part of every job's floor.
    let started = std::time::Instant::now();
    drop(ctx);
    let teardown_ms = 1e3 * started.elapsed().as_secs_f64();
    if let Some(s) = startup {
        println!("{}", startup_line(&s, teardown_ms));
    }
    Ok(())
}

/// The line `envlight devices` reports its context's start-up and teardown with (read back by
/// `cargo xtask lab peers`).
pub fn startup_line(s: &crate::gpu::Startup, teardown_ms: f64) -> String {
    format!(
        "start-up ms: loader {:.1}, instance {:.1}, device {:.1}, rest {:.1}; teardown ms {:.1}",
        s.loader_ms, s.instance_ms, s.device_ms, s.rest_ms, teardown_ms
    )
}
