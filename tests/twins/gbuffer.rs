//! The G-buffer pass against the float64 ray cast.
//! `tests/gbuffer.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::Errors;
use envlight::gpu::{Context, Timed};
use envlight::math::camera::{trace, Camera, Projection, Shape};
use envlight::passes::gbuffer::{GBufferPass, Object};
use glam::DVec3;

/// The bound [`check`] holds normals and positions to.
pub const BOUND: f64 = 1e-4;

/// Three spheres (one far, one small), a plane they stand on, cut to a disc, seen nearly
/// edge-on by one of the cameras.
pub fn objects() -> Vec<Object> {
    let sphere = |center: [f64; 3], radius: f64| Object {
        shape: Shape::Sphere { center, radius },
        albedo: [0.5; 3],
    };
    vec![
        sphere([0.0, 0.0, 0.0], 1.0),
        sphere([-2.2, -0.4, -0.5], 0.6),
        sphere([1.9, -0.7, 0.8], 0.3),
        sphere([0.5, 2.0, -30.0], 4.0),
        Object {
            shape: Shape::Plane {
                normal: [0.0, 1.0, 0.0],
                offset: -1.0,
                extent: 6.0,
            },
            albedo: [0.5; 3],
        },
    ]
}

pub fn cameras() -> [Camera; 3] {
    let camera = |projection, eye: [f64; 3], width, height| Camera {
        projection,
        eye,
        target: [0.0, -0.2, 0.0],
        up: [0.0, 1.0, 0.0],
        width,
        height,
    };
    [
        camera(
            Projection::Perspective { fov_y: 45.0 },
            [0.5, 1.5, 6.0],
            67,
            41,
        ),
        camera(
            Projection::Orthographic { height: 5.0 },
            [3.0, 4.0, 5.0],
            33,
            35,
        ),
        // Just above the plane: most of it is seen at grazing incidence.
        camera(
            Projection::Perspective { fov_y: 60.0 },
            [0.0, -0.9, 7.0],
            48,
            27,
        ),
    ]
}

/// Each pixel against the float64 ray cast through its centre. Pixels whose hit float32
/// cannot decide (margin under 1e-3: silhouettes, the disc's rim, near-ties) are left out and
/// counted; every other hit must be on the same object, with its normal within 1e-4 and its
/// position within 1e-4 · (1 + distance) of float64's: f32 intersections lose ~1e-7 relative
/// per operation, and a margin of 1e-3 bounds the amplification of a sphere's square root by
/// ~1/√margin ≈ 30, which leaves an order of magnitude to spare. Misses carry index −1 and
/// minus the ray's direction; every texel is finite.
pub fn check(ctx: &Context) {
    let pass = GBufferPass::new(ctx).unwrap();
    let objects = objects();
    let shapes: Vec<Shape> = objects.iter().map(|o| o.shape).collect();
    let records: Vec<_> = objects.iter().map(|o| o.gpu(2)).collect();
    let mut all_misses = 0;
    for (c, cam) in cameras().iter().enumerate() {
        let Timed {
            value: g,
            timings: t,
        } = pass.run(cam, &records).unwrap();
        assert_eq!(t[0].label, "gbuffer");
        let normal = g.normal.download_level(ctx, 0).unwrap();
        let position = g.position.download_level(ctx, 0).unwrap();
        let view = g.view.download_level(ctx, 0).unwrap();
        let (mut hits, mut misses, mut skipped) = (0, 0, 0);
        let (mut worst_n, mut worst_p) = (Errors::new(), Errors::new());
        for j in 0..cam.height {
            for i in 0..cam.width {
                let k = (j * cam.width + i) as usize;
                let at = format!("camera {c}, pixel ({i}, {j})");
                let f64x3 = |v: [f32; 4]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
                for v in [normal[k], position[k], view[k]] {
                    assert!(v.iter().all(|x| x.is_finite()), "{at}: {v:?}");
                }
                let (o, d) = cam.ray(i, j);
                let Some(hit) = trace(&shapes, o, d) else {
                    misses += 1;
                    assert_eq!(normal[k][3], -1.0, "{at}: a miss with an object index");
                    assert!((f64x3(view[k]) + d).length() < 1e-5, "{at}: {:?}", view[k]);
                    continue;
                };
                if hit.margin < 1e-3 {
                    skipped += 1;
                    continue;
                }
                hits += 1;
                assert_eq!(normal[k][3], hit.index as f32, "{at}: another object");
                let p = o + hit.t * d;
                let dn = (f64x3(normal[k]) - hit.normal).length();
                let dp = (f64x3(position[k]) - p).length() / (1.0 + hit.t);
                let dt = (position[k][3] as f64 - hit.t).abs() / (1.0 + hit.t);
                let dv = (f64x3(view[k]) + d).length();
                worst_n.add(dn, (i, j));
                worst_p.add(dp, (i, j));
                worst_p.add(dt, (i, j));
                assert!(dn < BOUND, "{at}: normal off by {dn:e}");
                assert!(
                    dp < BOUND && dt < BOUND,
                    "{at}: position off by {dp:e}, t {dt:e}"
                );
                assert!(dv < 1e-5, "{at}: view off by {dv:e}");
            }
        }
        eprintln!(
            "camera {c}: {hits} hits, {misses} misses, {skipped} undecidable; worst normal \
             {:.1e}, position {:.1e}",
            worst_n.worst(),
            worst_p.worst()
        );
        assert!(hits > 4 * skipped, "camera {c}: too few decided hits");
        all_misses += misses;
    }
    assert!(all_misses > 100, "the cameras see too little background");
}
