//! Recipe against reference: what the consumer's recipe (split-sum from the files, E/π from
//! the irradiance cube) costs on a probe, against envlight's reference for the same pixels, in
//! float64 on the host, as the renderer's "FIS with lights" twin: the source's light texels
//! (everything above twice its mean) summed exactly through a light tree, plus, for GGX,
//! filtered importance sampling of the residual, and for the diffuse sphere the exact
//! irradiance sum over the residual reduced to about 8,000 texels ([`diffuse_side`]: block
//! means, power kept; the cosine is smooth at that scale). The view is the report's (`math::camera::sphere_camera`: a unit
//! sphere, orthographic, from (0, 0.3, 5)), at [`SIDE`]², so the figures read beside the
//! report's split-sum rows for the same probe and α.

use super::{shade, PreviewCubes, Sphere};
use crate::math::brdf::{local_view, Brdf, Frame};
use crate::math::camera::{sphere_camera, trace, Shape};
use crate::math::envmap::luminance;
use crate::math::exact::{ExactFilter, Query};
use crate::math::light_tree::LightTree;
use crate::math::lights::{
    cells_for, extract, lobe_scale, prepare_cells, ExtractOptions, LightTexel,
};
use crate::math::mip::Level;
use crate::math::{convert, fis, mip, Mapping};
use crate::EnvMap;
use glam::{DMat3, DVec3};

/// Side of the view, pixels (the report's quick set's).
pub const SIDE: u32 = 32;
/// FIS samples a pixel of a GGX sphere.
const GGX_SAMPLES: u32 = 256;
/// The residual's dual paraboloid, a side.
const DP_SIZE: u32 = 128;
/// The largest side of the map the diffuse reference sums, by mapping: about 8,000 texels
/// (a lat-long 128 wide, a cube of 32² faces, a paraboloid or angular map 64 a side).
pub fn diffuse_side(m: Mapping) -> u32 {
    match m {
        Mapping::LatLong => 128,
        Mapping::Cube => 32,
        _ => 64,
    }
}

/// The spheres compared (the mirror has no integral to err).
pub const COMPARED: [Sphere; 4] = [
    Sphere::Ggx(0.1),
    Sphere::Ggx(0.3),
    Sphere::Ggx(0.6),
    Sphere::Diffuse,
];

/// The reference's view of a source map, in its (file) frame: the residual's MIP chain and
/// its reduction, the light texels through a tree per compared sphere, and lights a bake
/// separated before.
pub struct Reference {
    chain: Vec<Level>,
    /// The residual reduced for the diffuse sum.
    small: EnvMap,
    /// Per sphere of [`COMPARED`]: its BRDF, lobe scale and the light texels' tree.
    trees: Vec<(Brdf, f64, std::sync::Arc<LightTree>)>,
    separated: Vec<LightTexel>,
}

fn brdf_of(s: Sphere) -> Brdf {
    match s {
        Sphere::Ggx(a) => crate::math::split_sum::ggx(a, true),
        _ => Brdf::Lambert,
    }
}

impl Reference {
    /// Extracts `source`'s lights as the renderer does for its chain
    /// (`ExtractOptions::chain`: everything above twice the mean), filters the residual's
    /// dual-paraboloid chain, and keeps `separated` (lights a bake took out of `source`
    /// before, file frame) to add at their centres.
    pub fn new(source: &EnvMap, separated: Vec<LightTexel>) -> Reference {
        let ex = extract(source, &ExtractOptions::chain());
        let small = match convert::reduce_to_fit(&ex.residual, diffuse_side(source.mapping)) {
            Some((m, _)) => m,
            None => ex.residual.clone(),
        };
        let (w, h) = Mapping::DualParaboloid.extent_for_size(DP_SIZE);
        let ss = crate::passes::Converter::supersampling(
            (source.mapping, source.width, source.height),
            (Mapping::DualParaboloid, w, h),
        )
        .min(2);
        let dp = convert::convert(
            &ex.residual,
            Mapping::DualParaboloid,
            DP_SIZE,
            DMat3::IDENTITY,
            ss,
        );
        // One tree per quadrature (cells a texel): the wider lobes share theirs.
        let mut built: Vec<(u32, std::sync::Arc<LightTree>)> = Vec::new();
        let trees = COMPARED
            .iter()
            .map(|s| {
                let brdf = brdf_of(*s);
                let scale = lobe_scale(&brdf).unwrap_or(1.0);
                let cells = cells_for(&ex, scale);
                let tree = match built.iter().find(|(c, _)| *c == cells) {
                    Some((_, t)) => t.clone(),
                    None => {
                        let lights = prepare_cells(source, &ex.lights, DMat3::IDENTITY, cells);
                        let t = std::sync::Arc::new(LightTree::new(lights));
                        built.push((cells, t.clone()));
                        t
                    }
                };
                (brdf, scale, tree)
            })
            .collect();
        Reference {
            chain: mip::chain(&dp),
            small,
            trees,
            separated,
        }
    }

    /// ∫ L·f·cos dω of sphere `s` at normal `n`, view `v` (file frame).
    pub fn radiance(&self, s: Sphere, n: DVec3, v: DVec3) -> [f64; 3] {
        self.values(s, &[(n, v)])[0]
    }

    /// [`Reference::radiance`] at each (normal, view) of `at`: the diffuse sums in one pass
    /// over the reduced residual.
    pub fn values(&self, s: Sphere, at: &[(DVec3, DVec3)]) -> Vec<[f64; 3]> {
        let Some(k) = COMPARED.iter().position(|c| *c == s) else {
            // The mirror: the residual along the reflection.
            return at
                .iter()
                .map(|&(n, v)| fis::lookup(&self.chain, 2.0 * n.dot(v) * n - v, 0.0))
                .collect();
        };
        let (brdf, scale, tree) = &self.trees[k];
        let residual: Vec<[f64; 3]> = match s {
            Sphere::Diffuse => {
                let queries: Vec<Query> =
                    at.iter().map(|&(n, _)| Query::Irradiance { n }).collect();
                ExactFilter::new(&self.small, DMat3::IDENTITY)
                    .evaluate(&queries)
                    .into_iter()
                    .map(|e| e.map(|x| x / std::f64::consts::PI))
                    .collect()
            }
            _ => {
                let bias = crate::scene::DEFAULT_FIS_BIAS_RESIDUAL;
                at.iter()
                    .map(|&(n, v)| {
                        fis::estimate(&self.chain, brdf, n, v, GGX_SAMPLES, bias, [0.0; 2])
                    })
                    .collect()
            }
        };
        at.iter()
            .zip(residual)
            .map(|(&(n, v), mut out)| {
                let lights = tree.sum_brdf(brdf, n, v, *scale, luminance(out));
                let frame = Frame::new(n);
                let wo = local_view(&frame, v);
                for (c, o) in out.iter_mut().enumerate() {
                    *o += lights[c];
                    for l in &self.separated {
                        *o += brdf.eval_cos(wo, frame.to_local(l.dir))
                            * l.omega
                            * l.radiance[c] as f64;
                    }
                }
                out
            })
            .collect()
    }
}

/// The reference at every pixel of the report's view that shows the sphere: what a recipe
/// is compared with. It needs only the source, so a bake computes it while the GPU works.
pub struct ReferenceView {
    /// (pixel index, normal, view) in the file frame.
    pixels: Vec<(usize, DVec3, DVec3)>,
    /// Per sphere of [`COMPARED`], per pixel.
    values: Vec<Vec<[f64; 3]>>,
}

impl ReferenceView {
    /// The reference of `reference` over the view's sphere pixels (a margin of 1e-3, as the
    /// report's) on even rows and columns: a quarter of the pixels, an even sample of the
    /// sphere for the relative RMS (the heat map shows each as a 2 × 2 block).
    pub fn new(reference: &Reference) -> ReferenceView {
        let cam = sphere_camera(SIDE);
        let sphere = [Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        }];
        let mut pixels = Vec::new();
        for j in 0..SIDE {
            for i in 0..SIDE {
                let (o, d) = cam.ray(i, j);
                if i % 2 == 1 || j % 2 == 1 {
                    continue;
                }
                if let Some(h) = trace(&sphere, o, d).filter(|h| h.margin >= 1e-3) {
                    pixels.push(((j * SIDE + i) as usize, h.normal, -d));
                }
            }
        }
        let at: Vec<(DVec3, DVec3)> = pixels.iter().map(|&(_, n, v)| (n, v)).collect();
        let values = COMPARED.iter().map(|s| reference.values(*s, &at)).collect();
        ReferenceView { pixels, values }
    }
}

/// Recipe against reference per sphere of [`COMPARED`]: relative RMS over the sphere's
/// pixels (all channels, as the report's), and a [`SIDE`]² map per sphere of each pixel's
/// luminance error over the sphere's mean luminance (NaN off the sphere).
pub struct RecipeCheck {
    /// Relative RMS, in [`COMPARED`]'s order.
    pub errors: Vec<f64>,
    /// Per sphere, row by row.
    pub heat: Vec<Vec<f64>>,
}

/// Compares the recipe on `files` (cube frame; `file_to_cube` turns the file frame's
/// directions into it) with `view`.
pub fn recipe_check(
    files: &PreviewCubes,
    file_to_cube: DMat3,
    view: &ReferenceView,
) -> RecipeCheck {
    let mut errors = Vec::new();
    let mut heat = Vec::new();
    for (s, want) in COMPARED.iter().zip(&view.values) {
        let mut map = vec![f64::NAN; (SIDE * SIDE) as usize];
        let (mut se, mut sm2, mut ym) = (0.0, 0.0, 0.0);
        let mut dys = Vec::with_capacity(want.len());
        for (&(k, n, v), want) in view.pixels.iter().zip(want) {
            let got = shade(files, *s, file_to_cube * n, file_to_cube * v);
            for c in 0..3 {
                se += (got[c] - want[c]).powi(2);
                sm2 += want[c] * want[c];
            }
            ym += luminance(*want);
            dys.push((k, (luminance(got) - luminance(*want)).abs()));
        }
        let ym = ym / want.len().max(1) as f64;
        for (k, dy) in dys {
            map[k] = if ym > 0.0 { dy / ym } else { 0.0 };
        }
        errors.push(if sm2 > 0.0 { (se / sm2).sqrt() } else { 0.0 });
        heat.push(map);
    }
    RecipeCheck { errors, heat }
}
