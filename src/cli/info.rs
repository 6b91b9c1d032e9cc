//! `envlight info`, `devices` and `synth-sky`.

use super::{context, load_input, Global, Input};
use anyhow::Result;
use clap::Args;
use envlight::io;
use envlight::math::synth::Sky;
use envlight::{EnvMap, Mapping};
use std::path::PathBuf;

/// Print a map's mapping, size, radiance statistics and total power
#[derive(Args)]
pub struct InfoArgs {
    #[command(flatten)]
    input: Input,
}

/// Write the analytic sky (gradient, sun 5·10⁴ × the zenith, ground) as a lat-long EXR
#[derive(Args)]
pub struct SynthSkyArgs {
    /// Output EXR
    #[arg(short, long)]
    output: PathBuf,
    /// Width (height is half)
    #[arg(long, default_value_t = 256)]
    width: u32,
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
    println!(
        "timestamp period {} ns, {} valid bits",
        i.timestamp_period, i.timestamp_valid_bits
    );
    Ok(())
}

/// `envlight synth-sky`.
pub fn synth_sky(a: &SynthSkyArgs) -> Result<()> {
    let w = a.width.max(2);
    let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 8, |d| {
        Sky::default().radiance(d)
    });
    io::save_exr(&map, &a.output)?;
    let s = map.stats();
    println!(
        "wrote {} ({} x {}, max luminance {:.3e})",
        a.output.display(),
        w,
        w / 2,
        s.max_luminance
    );
    Ok(())
}
