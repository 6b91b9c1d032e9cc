//! What the bake tests share: scratch folders, three small probes written as EXR, small
//! options, and a walk over a folder.

use envlight::bake::BakeOptions;
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::Mapping;
use envlight::EnvMap;
use std::path::{Path, PathBuf};

pub fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("envlight-bake-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn probes(dir: &Path) -> Vec<EnvMap> {
    let sky = Sky::default();
    let maps = vec![
        EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env),
        EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, move |d| sky.radiance(d)),
        EnvMap::from_fn(Mapping::LatLong, 48, 24, 2, |d| {
            let s = smooth_env(d);
            [s[2], s[0], s[1]]
        }),
    ];
    for (k, m) in maps.iter().enumerate() {
        envlight::io::save_exr(m, dir.join(format!("p{k}.exr"))).unwrap();
    }
    maps
}

pub fn small_options() -> BakeOptions {
    let mut o = BakeOptions::default();
    (
        o.specular_size,
        o.specular_levels,
        o.irradiance_size,
        o.samples,
    ) = (16, 4, 8, 16);
    o
}

pub fn walk(d: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(d).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}
