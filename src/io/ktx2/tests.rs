//! The unit tests of `ktx2` (a file of their own: the module stays readable).

use super::*;

/// Every format this build writes (BC6H with feature `bc6h`).
fn written_formats() -> Vec<Ktx2Format> {
    let mut v = vec![
        Ktx2Format::Rgba16f,
        Ktx2Format::Rgba32f,
        Ktx2Format::B10g11r11,
        Ktx2Format::E5b9g9r9,
    ];
    if cfg!(feature = "bc6h") {
        v.push(Ktx2Format::Bc6h);
    }
    v
}

/// Without the encoder, BC6H is refused by name; with it, written.
#[test]
fn bc6h_is_written_only_with_its_encoder() {
    let levels = vec![vec![[0.5f32, 1.0, 2.0, 1.0]; 6 * 16]];
    let made = encode_with(
        &Ktx2Image::cube(4, &levels),
        Ktx2Format::Bc6h,
        Supercompression::None,
    );
    match cfg!(feature = "bc6h") {
        true => assert_eq!(decode(&made.unwrap()).unwrap().format, Ktx2Format::Bc6h),
        false => assert!(made.unwrap_err().to_string().contains("`bc6h` feature")),
    }
}

#[test]
fn dfd_is_the_basic_block_for_four_float_channels() {
    let d = dfd(Ktx2Format::Rgba16f);
    assert_eq!(d.len(), 4 + 24 + 64);
    assert_eq!(u32::from_le_bytes(d[0..4].try_into().unwrap()), 92);
    assert_eq!(d[20], 8); // bytesPlane0: 4 × 2 bytes
                          // Alpha's sample: offset 48, 16 bits, channel 15 | float | signed.
    let a = &d[28 + 48..28 + 64];
    assert_eq!(u16::from_le_bytes([a[0], a[1]]), 48);
    assert_eq!((a[2], a[3]), (15, 15 | 0xC0));
}

/// Decodes an unsigned float of 5 exponent and `m` mantissa bits from its definition.
fn unpack_ufloat(bits: u32, m: u32) -> f64 {
    let (e, q) = ((bits >> m) as i32, (bits & ((1 << m) - 1)) as f64);
    let one = (1u32 << m) as f64;
    if e == 0 {
        2f64.powi(-14) * q / one
    } else {
        2f64.powi(e - 15) * (1.0 + q / one)
    }
}

#[test]
fn packed_floats_round_to_nearest_and_refuse_what_they_cannot_hold() {
    for m in [5, 6] {
        let ulp = 2f64.powi(-(m as i32));
        // Every code round-trips; midpoints between codes go to the even one.
        for bits in 0..(31u32 << m) {
            let v = unpack_ufloat(bits, m);
            assert_eq!(pack_ufloat(v as f32, m), Some(bits), "m {m} bits {bits}");
            let next = unpack_ufloat(bits + 1, m);
            let mid = 0.5 * (v + next);
            if bits + 1 < (31 << m) && (mid as f32) as f64 == mid {
                let want = if bits % 2 == 0 { bits } else { bits + 1 };
                assert_eq!(pack_ufloat(mid as f32, m), Some(want), "mid of {bits}");
            }
        }
        // Relative error at most half an ulp across the range.
        let mut v = 1e-3f64;
        while v < 6e4 {
            let got = unpack_ufloat(pack_ufloat(v as f32, m).unwrap(), m);
            assert!((got - v).abs() <= 0.5 * ulp * v * 1.0001, "{v} -> {got}");
            v *= 1.37;
        }
        let max = unpack_ufloat((31 << m) - 1, m) as f32;
        assert!(pack_ufloat(max, m).is_some());
        assert!(pack_ufloat(max * 1.01, m).is_none());
        assert!(pack_ufloat(-1.0, m).is_none());
        assert!(pack_ufloat(f32::NAN, m).is_none());
    }
}

#[test]
fn shared_exponent_keeps_the_largest_channel_to_half_an_ulp() {
    let unpack = |w: u32| {
        let e = (w >> 27) as i32;
        let s = 2f64.powi(e - 15 - 9);
        [w & 511, (w >> 9) & 511, (w >> 18) & 511].map(|q| q as f64 * s)
    };
    for c in [
        [1.0f32, 0.5, 0.25],
        [65408.0, 1.0, 0.0],
        [3.1e-5, 0.0, 7.0e-6],
        [0.0, 0.0, 0.0],
        [1000.0, 999.9, 0.001],
        [511.75, 2.0, 3.0],
    ] {
        let got = unpack(pack_e5b9g9r9(c).unwrap());
        let top = c.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
        for k in 0..3 {
            // Each channel within half a step of the shared exponent's mantissa.
            assert!(
                (got[k] - c[k] as f64).abs() <= top / 511.0 + 1e-12,
                "{c:?} -> {got:?}"
            );
        }
    }
    assert!(pack_e5b9g9r9([65409.0, 0.0, 0.0]).is_none());
    assert!(pack_e5b9g9r9([1.0, -0.5, 0.0]).is_none());
}

#[test]
fn packed_dfds_describe_their_bits() {
    let d = dfd(Ktx2Format::B10g11r11);
    assert_eq!(d.len(), 4 + 24 + 48);
    assert_eq!(d[20], 4);
    let b = &d[28 + 32..28 + 48];
    assert_eq!(
        (u16::from_le_bytes([b[0], b[1]]), b[2], b[3]),
        (22, 9, 2 | 0x80)
    );
    let d = dfd(Ktx2Format::E5b9g9r9);
    assert_eq!(d.len(), 4 + 24 + 96);
    let exp_g = &d[28 + 48..28 + 64];
    assert_eq!(
        (u16::from_le_bytes([exp_g[0], exp_g[1]]), exp_g[2], exp_g[3]),
        (27, 4, 1 | 0x20)
    );
    assert_eq!(u32::from_le_bytes(exp_g[8..12].try_into().unwrap()), 15);
    let mant_b = &d[28 + 64..28 + 80];
    assert_eq!(u32::from_le_bytes(mant_b[12..16].try_into().unwrap()), 8448);
}

/// Reads a level index: (offset, stored bytes, uncompressed bytes) per level.
fn level_index(file: &[u8]) -> Vec<(u64, u64, u64)> {
    let n = u32::from_le_bytes(file[40..44].try_into().unwrap()) as usize;
    let word = |at: usize| u64::from_le_bytes(file[at..at + 8].try_into().unwrap());
    (0..n)
        .map(|k| (word(80 + 24 * k), word(88 + 24 * k), word(96 + 24 * k)))
        .collect()
}

/// Levels start at the smallest padding to lcm(block bytes, 4) after the previous one ends
/// (the key/value data for the smallest level): `ktx validate` refuses any other offset
/// (its error 4004); supercompressed levels follow each other unpadded.
#[test]
fn levels_are_padded_minimally() {
    let levels: Vec<Vec<[f32; 4]>> = (0..4)
        .map(|k| {
            let s = 8usize >> k;
            (0..6 * s * s)
                .map(|i| [i as f32 * 0.25, 1.0, 2.0, 1.0])
                .collect()
        })
        .collect();
    let img = Ktx2Image::cube(8, &levels);
    for format in written_formats() {
        for sc in [Supercompression::None, Supercompression::Zstd] {
            let file = encode_with(&img, format, sc).unwrap();
            let index = level_index(&file);
            let kv_end = u32::from_le_bytes(file[56..60].try_into().unwrap()) as u64
                + u32::from_le_bytes(file[60..64].try_into().unwrap()) as u64;
            let align = match sc {
                Supercompression::None => format.block_bytes().max(4) as u64,
                Supercompression::Zstd => 1,
            };
            let mut end = kv_end;
            for &(offset, len, raw) in index.iter().rev() {
                assert_eq!(offset, end.next_multiple_of(align), "{format:?} {sc:?}");
                end = offset + len;
                if sc == Supercompression::None {
                    assert_eq!(len, raw);
                }
            }
            assert_eq!(end, file.len() as u64, "{format:?} {sc:?}: trailing bytes");
            // Each level's stored bytes inflate to the uncompressed encoding's.
            if sc == Supercompression::Zstd {
                let plain = encode_with(&img, format, Supercompression::None).unwrap();
                for (&(o, l, raw), &(po, pl, _)) in index.iter().zip(&level_index(&plain)) {
                    let mut d = ruzstd::decoding::StreamingDecoder::new(
                        &file[o as usize..(o + l) as usize],
                    )
                    .unwrap();
                    let mut got = Vec::new();
                    std::io::Read::read_to_end(&mut d, &mut got).unwrap();
                    assert_eq!(got.len() as u64, raw);
                    assert_eq!(got, plain[po as usize..(po + pl) as usize]);
                }
            }
        }
    }
}

/// Every format, with and without Zstandard, decodes back to what was encoded to the
/// format's precision (exactly for rgba32f; BC6H to 2% of the level's brightest texel on
/// these smooth ramps); bad files are refused, not read past.
#[test]
fn decode_reads_back_what_encode_writes() {
    let levels: Vec<Vec<[f32; 4]>> = (0..3)
        .map(|k| {
            let s = 8usize >> k;
            (0..6 * s * s)
                .map(|i| [1.0 + i as f32 * 0.01, 2.0 + (i % 8) as f32 * 0.02, 0.5, 1.0])
                .collect()
        })
        .collect();
    let img = Ktx2Image::cube(8, &levels);
    let formats = [
        (Ktx2Format::Rgba32f, 0.0),
        (Ktx2Format::Rgba16f, 2f32.powi(-11)),
        (Ktx2Format::B10g11r11, 2f32.powi(-6)),
        (Ktx2Format::E5b9g9r9, 2f32.powi(-8)),
        (Ktx2Format::Bc6h, 0.02),
    ];
    let written = written_formats();
    for (format, rel) in formats.into_iter().filter(|(f, _)| written.contains(f)) {
        for sc in [Supercompression::None, Supercompression::Zstd] {
            let file = encode_with(&img, format, sc).unwrap();
            let t = decode(&file).unwrap();
            assert_eq!(
                (t.format, t.supercompression, t.width, t.faces),
                (format, sc, 8, 6)
            );
            for (got, want) in t.levels.iter().zip(&levels) {
                let top = want
                    .iter()
                    .flat_map(|t| &t[..3])
                    .fold(0.0f32, |a, &b| a.max(b));
                for (g, w) in got.iter().zip(want) {
                    for c in 0..3 {
                        let err = (g[c] - w[c]).abs();
                        let bound = if format == Ktx2Format::Bc6h {
                            rel * top
                        } else {
                            rel * w[0].max(w[1]).max(w[2])
                        };
                        assert!(err <= bound, "{format:?} {sc:?}: {g:?} {w:?}");
                    }
                }
            }
            // Truncated, or a level pointing past the end: refused.
            assert!(decode(&file[..file.len() - 1]).is_err());
            let mut bad = file.clone();
            bad[80..88].copy_from_slice(&u64::MAX.to_le_bytes());
            assert!(decode(&bad).is_err());
        }
    }
    assert!(decode(
        b"not a ktx file at all, but long enough to hold a header and more bytes.........."
    )
    .is_err());
    // Any byte of a valid file changed to any of a few values: read or refused, never a
    // panic or a huge allocation.
    for sc in [Supercompression::None, Supercompression::Zstd] {
        let packed = match cfg!(feature = "bc6h") {
            true => Ktx2Format::Bc6h,
            false => Ktx2Format::E5b9g9r9,
        };
        let file = encode_with(&img, packed, sc).unwrap();
        for at in 0..file.len().min(400) {
            for v in [0u8, 1, 0x7f, 0xff] {
                let mut m = file.clone();
                m[at] = v;
                let _ = decode(&m);
            }
        }
    }
}

#[test]
fn clamping_keeps_what_a_format_holds() {
    let mut levels = vec![vec![[1e6f32, -2.0, 3.0, 1.0], [7e4, 6.5e4, 6.46e4, 1.0]]];
    let c = clamp_levels(Ktx2Format::B10g11r11, &mut levels);
    assert_eq!(levels[0][0], [65024.0, 0.0, 3.0, 1.0]);
    assert_eq!(levels[0][1], [65024.0, 65000.0, 64512.0, 1.0]);
    assert_eq!((c.high, c.negative), (3, 1));
    let mut levels = vec![vec![[1e6f32, -2.0, 3.0, 1.0]]];
    let c = clamp_levels(Ktx2Format::Rgba16f, &mut levels);
    assert_eq!(levels[0][0], [65504.0, -2.0, 3.0, 1.0]);
    assert_eq!((c.high, c.negative), (1, 0));
    let img = Ktx2Image {
        width: 1,
        height: 1,
        faces: 1,
        layers: 0,
        levels: &levels,
    };
    assert!(encode(&img, Ktx2Format::Rgba16f).is_ok());
}

#[test]
fn refuses_inconsistent_images() {
    let level = vec![[0.0f32; 4]; 3];
    let img = Ktx2Image {
        width: 2,
        height: 2,
        faces: 1,
        layers: 0,
        levels: std::slice::from_ref(&level),
    };
    assert!(encode(&img, Ktx2Format::Rgba32f).is_err());
    let big = vec![[1e6f32; 4]; 4];
    let img = Ktx2Image {
        width: 2,
        height: 2,
        faces: 1,
        layers: 0,
        levels: std::slice::from_ref(&big),
    };
    assert!(encode(&img, Ktx2Format::Rgba16f).is_err());
    assert!(encode(&img, Ktx2Format::B10g11r11).is_err());
    let e = encode(&img, Ktx2Format::E5b9g9r9).unwrap_err().to_string();
    assert!(e.contains("1000000"), "{e}");
    assert!(encode(&img, Ktx2Format::Rgba32f).is_ok());
}
