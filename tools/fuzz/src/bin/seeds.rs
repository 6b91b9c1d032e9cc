//! Writes the starting inputs of every target into `seeds/` (small valid files of each format,
//! and the project's scene files), so a fuzz run starts inside each parser.

use envlight::{io, EnvMap, Mapping};
use std::path::Path;

fn texels(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| [i as f32 * 0.5, 1.0 / (1.0 + i as f32), 3.0])
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("seeds");
    let dir = |t: &str| {
        let d = root.join(t);
        std::fs::create_dir_all(&d).map(|_| d)
    };
    let ll = EnvMap::new(Mapping::LatLong, 4, 2, texels(8));
    io::save_exr(&ll, dir("exr")?.join("latlong.exr"))?;
    io::write_exr_half_channels(
        &dir("exr")?.join("bgr_half.exr"),
        2,
        1,
        &[("B", &[1.0, 2.0]), ("G", &[0.5, 0.25]), ("R", &[4.0, 8.0])],
    )?;
    io::write_pfm(&dir("pfm")?.join("latlong.pfm"), 4, 2, &texels(8))?;
    io::write_dds_cube(&dir("dds")?.join("cube.dds"), 2, &texels(24))?;
    let rgb8: Vec<u8> = (0..4 * 2 * 3).map(|i| (i * 37 % 256) as u8).collect();
    let img8 = image::RgbImage::from_raw(4, 2, rgb8).ok_or("rgb8")?;
    img8.save(dir("png")?.join("latlong.png"))?;
    img8.save(dir("jpeg")?.join("latlong.jpg"))?;
    let hdr: Vec<image::Rgb<f32>> = texels(8).into_iter().map(image::Rgb).collect();
    let f = std::fs::File::create(dir("hdr")?.join("latlong.hdr"))?;
    image::codecs::hdr::HdrEncoder::new(f).encode(&hdr, 4, 2)?;
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes");
    for e in std::fs::read_dir(scenes)? {
        let p = e?.path();
        std::fs::copy(&p, dir("scene")?.join(p.file_name().ok_or("name")?))?;
    }
    println!("wrote {}", root.display());
    Ok(())
}
