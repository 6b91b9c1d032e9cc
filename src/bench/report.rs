//! What accuracy costs in time on a user's probes (`envlight report`): every technique on
//! real probes and several materials, scored against the exact texel sums (or, asked for, a
//! converged Monte Carlo reference), with
//! its GPU time, its whole process's time and its frame when the environment changes every
//! frame. [`run`] measures; [`csv`] and [`super::pareto::markdown`] tabulate.

use super::cubes::PeerCube;
use crate::error::Result;
use crate::gpu::Context;
use crate::math::brdf::Brdf;
use crate::math::camera::{sphere_camera, Camera};
use crate::passes::ExactShader;
use crate::passes::GpuEnvMap;
use crate::render::score::{
    errors, exact_own_error, exact_truth, exact_truth_gpu, scene, sphere_pixels, truth,
};
use crate::render::{PassKind, Renderer};
use crate::scene::{LightsMode, LookupFilter, Scene, SplitSumSettings, Technique};
use crate::EnvMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Pixels of each exact reference frame (a probe and a material) taken again by the float64
/// twin, spread over the sphere.
pub const TWIN_PIXELS: usize = 12;

/// Pixels of each exact reference frame taken again with twice the cells per lobe scale, the
/// change estimating the rule's own error (`render::score::exact_own_error`).
pub const REFINED_PIXELS: usize = 48;

/// Tolerance of the mirror's pixel-area mean (`math::area_mean`), relative to each pixel's
/// mean; its own error is estimated by its change from [`MIRROR_CHECK_TOL`]. On the four 1k
/// probes at 64² it is within 1.3e-5 relative RMS of the mean refined to a third of it.
pub const MIRROR_TOL: f64 = 3e-4;

/// The coarser tolerance the mirror's reference is taken again at, the change its own error.
pub const MIRROR_CHECK_TOL: f64 = 10.0 * MIRROR_TOL;

/// Which reference a material's rows are scored against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// The exact texel sums on the GPU (`passes::ExactShader`), a few pixels checked
    /// against the float64 twin.
    ExactGpu,
    /// The exact texel sums in float64 on the host (`ExactFilter::shade`, the twin itself).
    ExactHost,
    /// Monte Carlo: the mean of 16 renders (`render::score::truth`; their spread its noise).
    MonteCarlo,
    /// A mirror's pixel-area mean, what a footprint lookup estimates: each pixel's mean of
    /// the texels its reflection covers, by area (`math::area_mean`, to [`MIRROR_TOL`]); its
    /// noise the rms change from [`MIRROR_CHECK_TOL`].
    PixelAreaMean,
}

impl Reference {
    /// Its name in report.csv.
    pub fn name(self) -> &'static str {
        match self {
            Reference::ExactGpu => "exact (gpu)",
            Reference::ExactHost => "exact (host float64)",
            Reference::MonteCarlo => "monte carlo",
            Reference::PixelAreaMean => "pixel-area mean",
        }
    }
}

/// Where the exact reference's sums run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExactOn {
    /// On the GPU, unless the device is the CPU (lavapipe), where the float64 twin on the
    /// same cores is the faster (a 16² GGX 0.3 sphere of a 1k map: 3.0 s against 0.36 s).
    Auto,
    /// On the GPU.
    Gpu,
    /// On the host.
    Host,
}

/// What a report measures.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// The reduced set (two probes, two materials, fewer parameters, a 256² FIS paraboloid)
    /// that runs in a few minutes on lavapipe.
    pub quick: bool,
    /// Side of the sphere image.
    pub size: u32,
    /// The Monte Carlo reference's samples per pixel, halved (`render::score::truth`; used
    /// where `exact` is off, and by the cube scores).
    pub reference: u32,
    /// Score against the exact texel sums (`render::score::exact_truth`: no noise) instead
    /// of Monte Carlo renders; the mirror, a lookup with no integral, keeps the renders
    /// (which agree exactly).
    pub exact: bool,
    /// Split-sum's chain.
    pub split: SplitSumSettings,
    /// Where the exact reference is summed.
    pub exact_on: ExactOn,
    /// Only the probes of these file names (with or without .hdr); all of the set where
    /// empty.
    pub probes: Vec<String>,
}

impl ReportOptions {
    /// The defaults of a full (64²) or `quick` (24²) report, scored against the exact
    /// reference (the Monte Carlo one, when asked for: 2 × 16384 or 2 × 1024 spp).
    pub fn new(quick: bool) -> ReportOptions {
        ReportOptions {
            quick,
            size: if quick { 24 } else { 64 },
            reference: if quick { 1024 } else { 16384 },
            exact: true,
            split: SplitSumSettings::default(),
            exact_on: ExactOn::Auto,
            probes: Vec::new(),
        }
    }

    /// Whether the exact reference is summed on `ctx`'s GPU ([`ExactOn`]).
    pub fn exact_on_gpu(&self, ctx: &Context) -> bool {
        match self.exact_on {
            ExactOn::Gpu => true,
            ExactOn::Host => false,
            ExactOn::Auto => ctx.info().device_type != ash::vk::PhysicalDeviceType::CPU,
        }
    }

    /// The FIS paraboloid's side: 256² for quick runs (lavapipe converts it fast), else sized
    /// by the source.
    pub fn paraboloid(&self) -> Option<u32> {
        self.quick.then_some(256)
    }
}

/// What a report asks of its caller beside the probes.
pub struct Hooks<'a> {
    /// Whole-process seconds of a render of a scene whose environment is a file, as a user
    /// runs it (`envlight render`).
    pub process: &'a dyn Fn(&Scene) -> Result<f64>,
    /// A peer's cubes of a probe file (glTF-IBL-Sampler's), shaded by split-sum beside the
    /// GGX materials; none where there is no peer.
    pub peers: &'a dyn Fn(&Path) -> Result<Vec<PeerCube>>,
    /// Each measurement, in words, as it is made.
    pub progress: &'a dyn Fn(&str),
}

/// One measurement: a technique with its parameters, on a probe, for a material.
#[derive(Clone, Debug)]
pub struct Row {
    /// The probe (file name without .hdr).
    pub probe: String,
    /// What kind of light it is ("soft", "sun", "studio", "interior").
    pub kind: &'static str,
    /// The material's name.
    pub material: String,
    /// The technique's name.
    pub technique: &'static str,
    /// Its parameters ("N=64", "l=2", …; "(no lights)" where lights stay in the map).
    pub params: String,
    /// Relative RMS over the sphere against the reference.
    pub rms: f64,
    /// Mean bias against the reference.
    pub bias: f64,
    /// The worst 8 × 8 tile's |ratio − 1|.
    pub tile: f64,
    /// GPU ms of the render (precomputation and shading) that falls to this material's
    /// sphere: what its technique's spheres share counted whole, passes over pixels a share
    /// (`share`).
    pub gpu_ms: f64,
    /// Of which precomputation.
    pub pre_ms: f64,
    /// Wall seconds of the render in this process (the technique's spheres together).
    pub wall_s: f64,
    /// Wall seconds of `envlight render` as its own process (the same frame), on the first
    /// probe a run reads (its frame's process takes about as long on each 1k probe) and with
    /// the lights extracted (the default); NaN on the others.
    pub process_s: f64,
    /// The reference's own noise or error: its renders' standard error (Monte Carlo,
    /// `render::score::truth`); the mirror's pixel-area mean's change from a 10× coarser tolerance; the exact
    /// sums' worst change at [`REFINED_PIXELS`] pixels when their cells are doubled.
    pub noise: f64,
    /// The exact reference's worst relative error against its float64 twin at the pixels
    /// checked ([`TWIN_PIXELS`] a probe and material) where the GPU summed it; 0 otherwise.
    pub twin: f64,
    /// What the reference is: [`Reference::name`].
    pub reference: &'static str,
    /// GPU ms of a frame when the environment changes every frame: the resident path's
    /// whole frame (projection, extraction, chains, shading); Monte Carlo's host render
    /// (its sampling tables, rebuilt on the host at each change, not counted); a peer's
    /// bake (its whole process) plus split-sum's shading.
    pub frame_ms: f64,
    /// Relative RMS of that path's render.
    pub frame_rms: f64,
}

impl Row {
    /// The technique and its parameters, as the tables label it.
    pub fn label(&self) -> String {
        if self.params.is_empty() {
            self.technique.to_string()
        } else {
            format!("{} {}", self.technique, self.params)
        }
    }
}

/// The probes: (file, what kind of light it is).
fn probes(quick: bool) -> Vec<(&'static str, &'static str)> {
    let mut v = vec![
        ("venice_sunset_1k.hdr", "soft"),
        ("spiaggia_di_mondello_1k.hdr", "sun"),
    ];
    if !quick {
        v.push(("studio_small_08_1k.hdr", "studio"));
        // Grace Cathedral's interior, stored nadir-first (../shared/probes/SOURCES.md) and
        // scored as stored: every technique and the reference read the same map.
        v.push(("grace_latlong.exr", "interior"));
    }
    v
}

/// The materials: diffuse and GGX 0.3 in quick runs; else diffuse, the mirror, Phong 64,
/// GGX 0.05–0.6 and anisotropic Ward (αx 0.1, αy 0.4).
fn materials(quick: bool) -> Vec<(&'static str, Brdf)> {
    let ggx = |alpha| Brdf::Ggx {
        alpha,
        correlated: true,
    };
    if quick {
        return vec![("diffuse", Brdf::Lambert), ("ggx 0.3", ggx(0.3))];
    }
    vec![
        ("diffuse", Brdf::Lambert),
        ("mirror", Brdf::Mirror),
        ("phong 64", Brdf::Phong { n: 64.0 }),
        ("ggx 0.05", ggx(0.05)),
        ("ggx 0.1", ggx(0.1)),
        ("ggx 0.3", ggx(0.3)),
        ("ggx 0.6", ggx(0.6)),
        ("ward 0.1x0.4", Brdf::Ward { ax: 0.1, ay: 0.4 }),
    ]
}

/// Every technique kind a report knows, with a scene's technique of that kind: what
/// [`cannot_shade`] tries on each material.
fn every_technique() -> Vec<Technique> {
    vec![
        Technique::Lookup,
        Technique::Sh { order: 2 },
        Technique::Prefiltered { size: 32 },
        Technique::Fis {
            samples: 64,
            bias: None,
            rotate: true,
        },
        Technique::ShBrdf {
            order: 2,
            grid: crate::math::sh_brdf::DEFAULT_GRID,
            window: None,
        },
        Technique::SplitSum,
        Technique::Mc {
            samples: 64,
            error: None,
        },
    ]
}

/// The report's materials (`quick`'s or the full set's), each with the techniques that cannot
/// shade it (the scene's own check refuses them), named.
pub fn cannot_shade(quick: bool) -> Vec<(&'static str, Vec<&'static str>)> {
    let cam = sphere_camera(8);
    materials(quick)
        .into_iter()
        .map(|(name, brdf)| {
            let refused = every_technique()
                .into_iter()
                .filter(|&t| {
                    let sc = scene(cam, brdf, t, None, 1, SplitSumSettings::default());
                    sc.validate().is_err()
                })
                .map(|t| t.name())
                .collect();
            (name, refused)
        })
        .collect()
}

/// A technique to score: its label, split-sum taps, whether the probe's lights are
/// extracted (the default) or left in the map, and whether a mirror reads one texel a pixel
/// (else the pixel's footprint).
#[derive(Clone)]
struct Case {
    technique: Technique,
    label: String,
    taps: u32,
    extract: bool,
    point: bool,
}

/// The techniques that apply to `brdf`, each with light extraction and, where a technique
/// reads it (not the Monte Carlo reference), without; quick runs take the second row for SH
/// order 2, FIS 64 and split-sum only. The mirror's lookup also reads one texel a pixel.
fn cases(brdf: &Brdf, quick: bool) -> Vec<Case> {
    let with: Vec<(Technique, String, u32)> = techniques(brdf, quick);
    let mut v = Vec::new();
    let case = |technique, label, taps, extract| Case {
        technique,
        label,
        taps,
        extract,
        point: false,
    };
    for (t, label, taps) in with {
        let both = match t {
            Technique::Mc { .. } => false,
            _ if !quick => true,
            Technique::Sh { order } => order == 2,
            Technique::Fis { samples, .. } => samples == 64,
            Technique::SplitSum => taps == 1,
            _ => false,
        };
        if both {
            // No comma: the label is a CSV field.
            let off = match label.is_empty() {
                true => "(no lights)".to_string(),
                false => format!("{label} (no lights)"),
            };
            v.push(case(t, off, taps, false));
        }
        v.push(case(t, label, taps, true));
    }
    if matches!(brdf, Brdf::Mirror) {
        v.push(Case {
            point: true,
            ..case(Technique::Lookup, "point".into(), 1, false)
        });
    }
    v
}

/// The techniques that apply to `brdf`, with their labels and split-sum taps.
fn techniques(brdf: &Brdf, quick: bool) -> Vec<(Technique, String, u32)> {
    let (fis, mc, orders): (&[u32], &[u32], &[u32]) = if quick {
        (&[16, 64], &[64, 256], &[2, 8])
    } else {
        (&[4, 16, 64, 256], &[16, 64, 256, 1024], &[2, 4, 8])
    };
    let mut v = Vec::new();
    if matches!(brdf, Brdf::Mirror) {
        return vec![(Technique::Lookup, String::new(), 1)];
    }
    if matches!(brdf, Brdf::Lambert) {
        for &order in orders {
            v.push((Technique::Sh { order }, format!("l={order}")));
        }
    }
    if matches!(brdf, Brdf::Lambert | Brdf::Phong { .. }) && !quick {
        let size = if matches!(brdf, Brdf::Lambert) {
            32
        } else {
            64
        };
        v.push((Technique::Prefiltered { size }, format!("{size}")));
    }
    for &samples in fis {
        let t = Technique::Fis {
            samples,
            bias: None,
            rotate: true,
        };
        v.push((t, format!("N={samples}")));
    }
    for &samples in mc {
        let t = Technique::Mc {
            samples,
            error: None,
        };
        v.push((t, format!("N={samples}")));
    }
    for &order in orders {
        let t = Technique::ShBrdf {
            order,
            grid: crate::math::sh_brdf::DEFAULT_GRID,
            window: None,
        };
        v.push((t, format!("l={order}")));
    }
    let mut v: Vec<(Technique, String, u32)> = v.into_iter().map(|(t, l)| (t, l, 1)).collect();
    if matches!(brdf, Brdf::Ggx { .. }) {
        v.push((Technique::SplitSum, String::new(), 1));
        let taps = 8;
        v.push((Technique::SplitSum, format!("taps={taps}"), taps));
    }
    v
}

/// One render's cases: a case and the materials it shades, each drawn as its own sphere
/// beside the others in one frame ([`group_scene`]), as a renderer shades several
/// materials from one environment's precomputation.
struct Group {
    case: Case,
    /// (index of the material in [`materials`], index of the case in its [`cases`]).
    members: Vec<(usize, usize)>,
}

/// The cases of every material of the set, grouped: one group per technique, parameters,
/// taps, lights and lookup filter and per `shared(material's BRDF, case)`, what the
/// material's render would precompute ([`shared_work`]): materials whose precomputation
/// differs (a finer lobe asks for a larger paraboloid) are drawn apart.
fn groups(quick: bool, shared: impl Fn(Brdf, &Case) -> String) -> Vec<Group> {
    let mut groups: Vec<(String, Group)> = Vec::new();
    for (m, (_, brdf)) in materials(quick).into_iter().enumerate() {
        for (c, case) in cases(&brdf, quick).into_iter().enumerate() {
            let key = format!(
                "{:?} {} {} {} {} {}",
                case.technique,
                case.label,
                case.taps,
                case.extract,
                case.point,
                shared(brdf, &case)
            );
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, g)) => g.members.push((m, c)),
                None => groups.push((
                    key,
                    Group {
                        case,
                        members: vec![(m, c)],
                    },
                )),
            }
        }
    }
    groups.into_iter().map(|(_, g)| g).collect()
}

/// What a render of `sc` on a map of shape `map` precomputes, in words: its passes, the
/// paraboloid's conversion, the lights' extractions, the split-sum chain, the SH order and
/// Monte Carlo's budget (not the per-object SH-BRDF tables, split among the spheres).
fn shared_work(sc: &Scene, map: crate::render::MapShape) -> String {
    let plan = crate::render::plan::plan_for(sc, map);
    let kinds: Vec<PassKind> = plan.passes.iter().map(|p| p.kind).collect();
    format!(
        "{kinds:?} {:?} {:?} {:?} {} {:?}",
        plan.dp, plan.lights, plan.split, plan.lmax, plan.mc
    )
}

/// `base` (a scene of one sphere at the origin seen by the report's camera) with one sphere
/// per BRDF of `brdfs` side by side along the camera's right axis, each in a cell of the
/// camera's size: the frame is `brdfs.len()` cells wide and each cell's pixels see their
/// sphere exactly as the one camera sees the one sphere (an orthographic view, offsets of a
/// whole cell).
fn group_scene(base: &Scene, brdfs: &[Brdf]) -> Result<Scene> {
    let mut sc = base.clone();
    let cam = &mut sc.camera;
    let n = brdfs.len();
    let crate::math::camera::Projection::Orthographic { height } = cam.projection else {
        return Err(crate::Error::Invalid(
            "report: spheres are drawn together under an orthographic camera only".into(),
        ));
    };
    let cell = height * cam.width as f64 / cam.height as f64;
    cam.width *= n as u32;
    let template = base.objects[0].clone();
    sc.objects = brdfs
        .iter()
        .enumerate()
        .map(|(k, &brdf)| {
            let mut o = template.clone();
            o.shape = crate::math::camera::Shape::Sphere {
                center: [(k as f64 - 0.5 * (n as f64 - 1.0)) * cell, 0.0, 0.0],
                radius: 1.0,
            };
            o.material.kind = brdf;
            o
        })
        .collect();
    Ok(sc)
}

/// Cell `k` (of `size` × `size` pixels) of a frame of cells side by side.
fn cell_of(frame: &EnvMap, k: usize, size: u32) -> EnvMap {
    let (w, s) = (frame.width as usize, size as usize);
    let texels = (0..s)
        .flat_map(|j| {
            frame.texels[j * w + k * s..j * w + (k + 1) * s]
                .iter()
                .copied()
        })
        .collect();
    EnvMap::new(crate::Mapping::LatLong, size, size, texels)
}

/// One material's sphere of a group: its name, its reference (which, frame, noise, twin
/// error) and where its row goes.
struct Member<'a> {
    material: &'a str,
    truth: &'a (Reference, EnvMap, f64, f64),
    order: (usize, usize),
}

/// What a group is measured against: a probe (file, kind; on disk at `absolute`, in memory
/// and on the GPU) and each member's reference.
struct Against<'a> {
    process: &'a dyn Fn(&Scene) -> Result<f64>,
    progress: &'a dyn Fn(&str),
    renderer: &'a Renderer,
    probe: (&'a str, &'static str),
    absolute: &'a Path,
    env: &'a EnvMap,
    gpu: &'a GpuEnvMap,
    /// The side of each member's cell, and its scored pixels.
    size: u32,
    pixels: &'a [(usize, u32)],
    /// The pipeline sets already built ([`warm_key`]).
    warmed: &'a std::cell::RefCell<std::collections::HashSet<String>>,
    /// The frames whose whole process is timed already.
    processed: &'a std::cell::RefCell<std::collections::HashSet<String>>,
}

/// What decides the pipelines a case's render builds: its technique, BRDFs, lights and
/// lookup filter, on the host path or the resident one.
fn warm_key(sc: &Scene, resident: bool) -> String {
    let o = &sc.objects[0].material;
    let kinds: Vec<u32> = sc.objects.iter().map(|o| o.material.kind.id()).collect();
    format!(
        "{resident} {:?} {kinds:?} {:?} {:?}",
        o.technique, sc.environment.lights, sc.environment.filter
    )
}

/// GPU ms of `records` that fall to one of `n` spheres drawn together, and of it the
/// precomputation: passes over the frame's pixels (G-buffer, shading, Monte Carlo) and the
/// SH-BRDF tables (one per sphere's BRDF) split evenly, what the spheres share (conversions,
/// chains, projections, lights, prefiltered maps) counted whole.
fn share(records: &[crate::render::PassRecord], n: usize) -> (f64, f64) {
    let per_frame = |k: PassKind| {
        matches!(
            k,
            PassKind::GBuffer | PassKind::Shade | PassKind::MonteCarlo
        )
    };
    let split = |k: PassKind| per_frame(k) || k == PassKind::ShBrdfTable;
    let ms = |p: &crate::render::PassRecord| match split(p.kind) {
        true => p.ms() / n as f64,
        false => p.ms(),
    };
    let gpu: f64 = records.iter().map(ms).sum();
    // (+ 0.0: an empty float sum is −0.)
    let pre = records
        .iter()
        .filter(|p| !per_frame(p.kind))
        .map(ms)
        .sum::<f64>()
        + 0.0;
    (gpu, pre)
}

/// A group's rows: the host path's render of its spheres timed and each cell scored, the
/// whole process timed, and the frame of a changing environment (the resident path, except
/// Monte Carlo's).
fn measure(
    a: &Against<'_>,
    sc: &Scene,
    (t, params): (Technique, &str),
    members: &[Member<'_>],
) -> Result<Vec<((usize, usize), Row)>> {
    let n = members.len();
    // One untimed render first where this case's pipelines are not built yet (they are
    // built on first use).
    if a.warmed.borrow_mut().insert(warm_key(sc, false)) {
        a.renderer.render(sc, a.env)?;
    }
    let t0 = Instant::now();
    let r = a.renderer.render(sc, a.env)?;
    let wall_s = t0.elapsed().as_secs_f64();
    let mut on_disk = sc.clone();
    on_disk.environment.file = a.absolute.to_path_buf();
    // The process once per frame of the run (the first probe's), with the lights extracted
    // as a user's render does by default: it renders the same frame again, and its time is
    // the map's size's, not its content's.
    let brdfs: Vec<Brdf> = sc.objects.iter().map(|o| o.material.kind).collect();
    let extracted = !matches!(sc.environment.lights, LightsMode::None);
    let first = a
        .processed
        .borrow_mut()
        .insert(format!("{} {params} {brdfs:?}", warm_key(sc, false)));
    let process_s = match first && extracted {
        true => (a.process)(&on_disk)?,
        false => f64::NAN,
    };
    let (gpu_ms, pre_ms) = share(&r.records, n);
    let changing = match t {
        Technique::Mc { .. } => None,
        _ => {
            let warm = a.warmed.borrow_mut().insert(warm_key(sc, true));
            Some(changing_frame(a.renderer, sc, a.gpu, warm)?)
        }
    };
    let mut rows = Vec::new();
    for (k, m) in members.iter().enumerate() {
        let (reference, truth, noise, twin) = m.truth;
        let (rms, bias, tile) = errors(&cell_of(&r.frame, k, a.size), truth, a.pixels);
        let (frame_ms, frame_rms) = match &changing {
            None => (gpu_ms, rms),
            Some((records, frame)) => (
                share(records, n).0,
                errors(&cell_of(frame, k, a.size), truth, a.pixels).0,
            ),
        };
        let row = Row {
            probe: a.probe.0.trim_end_matches(".hdr").to_string(),
            kind: a.probe.1,
            material: m.material.to_string(),
            technique: t.name(),
            params: params.to_string(),
            rms,
            bias,
            tile,
            gpu_ms,
            pre_ms,
            wall_s,
            process_s,
            noise: *noise,
            twin: *twin,
            reference: reference.name(),
            frame_ms,
            frame_rms,
        };
        (a.progress)(&format!(
            "{:>28} {:>12} {:<16} rms {:>8.2e} bias {:>+9.2e} tile {:>8.2e} gpu {:>9.2} ms (pre {:>8.2}) wall {:.3} s ({n} spheres); changing: {:>9.2} ms rms {:>8.2e}",
            row.probe, row.material, row.label(), rms, bias, tile, gpu_ms, pre_ms, wall_s, frame_ms, frame_rms
        ));
        rows.push((m.order, row));
    }
    Ok(rows)
}

/// The resident path's frame of `sc` from `gpu` (`Renderer::resident`, one untimed frame
/// first where `warm`: pipelines are built on first use): its pass records and its frame.
fn changing_frame(
    renderer: &Renderer,
    sc: &Scene,
    gpu: &GpuEnvMap,
    warm: bool,
) -> Result<(Vec<crate::render::PassRecord>, EnvMap)> {
    let prepared = renderer.resident(
        sc,
        crate::render::MapShape {
            mapping: gpu.mapping,
            width: gpu.width,
            height: gpu.height,
        },
    )?;
    if warm {
        renderer.render_resident(&prepared, gpu)?;
    }
    let r = renderer.render_resident(&prepared, gpu)?;
    Ok((r.records, r.frame))
}

/// The rows of glTF-IBL-Sampler's cubes of `file` (`at`: file, probe kind, material) for a
/// GGX `brdf`: each shaded by split-sum in float64 and scored against `truth`. Its bake is
/// precomputation, timed as its whole process (it has no timestamps, so its wall time bounds
/// its GPU time): with one environment a frame costs split-sum's `shading` ms, and when the
/// environment changes every frame, the bake as well.
fn peer_rows(
    peers: &[super::cubes::PeerCube],
    (file, kind, material): (&str, &'static str, &str),
    brdf: Brdf,
    cam: &Camera,
    (truth, noise, twin, reference): (&EnvMap, f64, f64, Reference),
    shading: f64,
) -> Vec<Row> {
    let Brdf::Ggx { alpha, .. } = brdf else {
        return Vec::new();
    };
    let table = crate::math::split_sum::dfg_table(super::cubes::DFG_SIZE, true);
    let pixels = sphere_pixels(cam);
    peers
        .iter()
        .map(|p| {
            let f = super::cubes::shade_frame(cam, &p.chain, &table, alpha, 1);
            let (rms, bias, tile) = errors(&f, truth, &pixels);
            Row {
                probe: file.trim_end_matches(".hdr").to_string(),
                kind,
                material: material.to_string(),
                technique: super::cubes::PEER,
                params: format!("N={}", p.samples),
                rms,
                bias,
                tile,
                gpu_ms: 1e3 * p.seconds + shading,
                pre_ms: 1e3 * p.seconds,
                wall_s: p.seconds,
                process_s: p.seconds,
                noise,
                twin,
                reference: reference.name(),
                frame_ms: 1e3 * p.seconds + shading,
                frame_rms: rms,
            }
        })
        .collect()
}

/// What [`run`] measured: the rows, and the probes left out with the reason.
pub struct Report {
    /// One row per technique × parameters × probe × material.
    pub rows: Vec<Row>,
    /// "file: why" for each probe that could not be read.
    pub skipped: Vec<String>,
}

/// What every probe's measurements share: the passes, the camera and its scored pixels, the
/// options, and the pipeline sets already built (a case whose set is built needs no untimed
/// render first).
struct Session<'a> {
    ctx: &'a Context,
    renderer: Renderer,
    exact_pass: ExactShader,
    cam: Camera,
    pixels: Vec<(usize, u32)>,
    o: &'a ReportOptions,
    hooks: &'a Hooks<'a>,
    warmed: std::cell::RefCell<std::collections::HashSet<String>>,
    /// The frames whose whole process is timed already (on the first probe).
    processed: std::cell::RefCell<std::collections::HashSet<String>>,
}

/// Measures every case on the probes of `dir` (venice_sunset and spiaggia_di_mondello, and in
/// full runs studio_small_08 and grace_latlong): one row per technique × parameters × probe ×
/// material. A probe that cannot be read is left out and named with the reason; an error
/// where none can be.
pub fn run(ctx: &Context, dir: &Path, o: &ReportOptions, hooks: &Hooks) -> Result<Report> {
    let cam = sphere_camera(o.size);
    let session = Session {
        ctx,
        renderer: Renderer::new(ctx),
        exact_pass: ExactShader::new(ctx)?,
        cam,
        pixels: sphere_pixels(&cam),
        o,
        hooks,
        warmed: Default::default(),
        processed: Default::default(),
    };
    let mut report = Report {
        rows: Vec::new(),
        skipped: Vec::new(),
    };
    let named = |file: &str, p: &str| file == p || file.rsplit_once('.').map(|f| f.0) == Some(p);
    if let Some(p) = o
        .probes
        .iter()
        .find(|p| !probes(o.quick).iter().any(|f| named(f.0, p)))
    {
        return Err(crate::Error::Invalid(format!(
            "report: no probe of the set is named {p:?} (the set: {})",
            probes(o.quick)
                .iter()
                .map(|p| p.0)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let set: Vec<_> = probes(o.quick)
        .into_iter()
        .filter(|f| o.probes.is_empty() || o.probes.iter().any(|p| named(f.0, p)))
        .collect();
    for (file, kind) in set {
        let path = dir.join(file);
        let loaded = path
            .canonicalize()
            .map_err(|source| crate::Error::Io {
                path: path.clone(),
                source,
            })
            .and_then(|absolute| {
                let env = crate::io::load(&path, &crate::io::LoadOptions::default())?;
                Ok((absolute, env))
            });
        let (absolute, env) = match loaded {
            Ok(l) => l,
            Err(e) => {
                (hooks.progress)(&format!("report: {} left out: {e}", path.display()));
                report.skipped.push(format!("{file}: {e}"));
                continue;
            }
        };
        let probe = LoadedProbe {
            file,
            kind,
            absolute: &absolute,
            env: &env,
            peers: (hooks.peers)(&path)?,
            // The map on the GPU once, for the resident path's frames and the exact sums.
            gpu: GpuEnvMap::upload(ctx, &env)?,
        };
        report.rows.extend(session.probe_rows(&probe)?);
    }
    if report.rows.is_empty() && !report.skipped.is_empty() {
        return Err(crate::Error::Invalid(format!(
            "report: no probe could be read (set --probes): {}",
            report.skipped.join("; ")
        )));
    }
    Ok(report)
}

/// A probe read for a report: its file name and kind, where it is, the map in memory and on
/// the GPU, and the peers' cubes of it.
struct LoadedProbe<'a> {
    file: &'static str,
    kind: &'static str,
    absolute: &'a Path,
    env: &'a EnvMap,
    gpu: GpuEnvMap,
    peers: Vec<PeerCube>,
}

impl Session<'_> {
    /// `brdf`'s reference frame on `p` (the report's scenes take the map as loaded, the
    /// default orientation): which it is, the frame, its noise and its twin error.
    fn reference(
        &self,
        p: &LoadedProbe,
        name: &str,
        brdf: Brdf,
    ) -> Result<(Reference, EnvMap, f64, f64)> {
        let (o, cam) = (self.o, self.cam);
        let world_to_file = crate::math::Orientation::default().world_to_file();
        // The mirror's is the pixel-area mean its footprint lookup estimates (a pixel
        // centre's texel is a point sample of a step at a sun's rim).
        let reference = match (o.exact, o.exact_on_gpu(self.ctx)) {
            _ if matches!(brdf, Brdf::Mirror) => Reference::PixelAreaMean,
            (true, true) => Reference::ExactGpu,
            (true, false) => Reference::ExactHost,
            (false, _) => Reference::MonteCarlo,
        };
        let own_error = |frame: &EnvMap| {
            let own = exact_own_error(&cam, brdf, p.env, world_to_file, frame, REFINED_PIXELS);
            (self.hooks.progress)(&format!(
                "{} {name}: exact reference, its own error by refinement at {REFINED_PIXELS} pixels: {own:.1e}",
                p.file
            ));
            own
        };
        let (frame, noise, twin) = match reference {
            Reference::ExactGpu => {
                let maps = (p.env, &p.gpu);
                let e = exact_truth_gpu(
                    &self.exact_pass,
                    &cam,
                    brdf,
                    maps,
                    world_to_file,
                    TWIN_PIXELS,
                )?;
                (self.hooks.progress)(&format!(
                    "{} {name}: exact reference {:.0} GPU ms, {} pixels against the float64 twin: worst {:.1e}",
                    p.file, e.ms, e.checked, e.twin
                ));
                let own = own_error(&e.frame);
                (e.frame, own, e.twin)
            }
            Reference::ExactHost => {
                let frame = exact_truth(&cam, brdf, p.env, world_to_file);
                let own = own_error(&frame);
                (frame, own, 0.0)
            }
            Reference::PixelAreaMean => {
                let sphere = [crate::math::camera::Shape::Sphere {
                    center: [0.0; 3],
                    radius: 1.0,
                }];
                // The map as loaded: its file frame is the world's.
                let mean = |tol| crate::math::area_mean::area_mean(p.env, &cam, &sphere, tol).0;
                let (mean, coarse) = (mean(MIRROR_TOL), mean(MIRROR_CHECK_TOL));
                let own = errors(&coarse, &mean, &self.pixels).0;
                (mean, own, 0.0)
            }
            Reference::MonteCarlo => {
                let (dp, split) = (o.paraboloid(), o.split);
                let (t, n) = truth(&self.renderer, cam, brdf, dp, split, o.reference, p.env)?;
                (t, n, 0.0)
            }
        };
        Ok((reference, frame, noise, twin))
    }

    /// Every case of every material on probe `p`, a group's materials rendered together
    /// ([`groups`]), in the order of the materials and their cases, each material's peers'
    /// cubes after its cases.
    fn probe_rows(&self, p: &LoadedProbe) -> Result<Vec<Row>> {
        let (o, cam) = (self.o, self.cam);
        let (split, dp) = (o.split, o.paraboloid());
        let set = materials(o.quick);
        let truths = set
            .iter()
            .map(|&(name, brdf)| self.reference(p, name, brdf))
            .collect::<Result<Vec<_>>>()?;
        let one = |brdf: Brdf, c: &Case| {
            let split = SplitSumSettings {
                taps: c.taps,
                ..split
            };
            let mut sc = scene(cam, brdf, c.technique, dp, 7, split);
            if !c.extract {
                sc.environment.lights = LightsMode::None;
            }
            if c.point {
                sc.environment.filter = LookupFilter::Point;
            }
            sc
        };
        let shape = crate::render::MapShape::of(p.env);
        let mut rows = Vec::new();
        for g in groups(o.quick, |brdf, c| shared_work(&one(brdf, c), shape)) {
            let c = &g.case;
            let brdfs: Vec<Brdf> = g.members.iter().map(|&(m, _)| set[m].1).collect();
            let sc = group_scene(&one(brdfs[0], c), &brdfs)?;
            // Drawn together, the spheres precompute what each would alone.
            let alone = shared_work(&one(brdfs[0], c), shape);
            if shared_work(&sc, shape) != alone {
                return Err(crate::Error::Invalid(format!(
                    "report: {} {} on {} spheres plans other precomputation than one alone",
                    c.technique.name(),
                    c.label,
                    brdfs.len()
                )));
            }
            let members: Vec<Member> = g
                .members
                .iter()
                .map(|&(m, k)| Member {
                    material: set[m].0,
                    truth: &truths[m],
                    order: (m, k),
                })
                .collect();
            let at = Against {
                process: self.hooks.process,
                progress: self.hooks.progress,
                renderer: &self.renderer,
                probe: (p.file, p.kind),
                absolute: p.absolute,
                env: p.env,
                gpu: &p.gpu,
                size: cam.width,
                pixels: &self.pixels,
                warmed: &self.warmed,
                processed: &self.processed,
            };
            rows.extend(measure(&at, &sc, (c.technique, &c.label), &members)?);
        }
        rows.sort_by_key(|(order, _)| *order);
        let mut out = Vec::new();
        for (m, &(name, brdf)) in set.iter().enumerate() {
            let mine: Vec<Row> = rows
                .iter()
                .filter(|(order, _)| order.0 == m)
                .map(|(_, r)| r.clone())
                .collect();
            // The peers' cubes are shaded by split-sum: its per-frame shading cost here.
            let shading = mine
                .iter()
                .find(|r| r.technique == "split_sum" && r.params.is_empty())
                .map_or(0.0, |r| r.gpu_ms - r.pre_ms);
            let (reference, truth, noise, twin) = &truths[m];
            let at = (p.file, p.kind, name);
            let scored = (truth, *noise, *twin, *reference);
            out.extend(mine);
            out.extend(peer_rows(&p.peers, at, brdf, &cam, scored, shading));
        }
        Ok(out)
    }
}

/// The rows of a report.csv that [`csv`] wrote (to redraw its chart without measuring again);
/// an error naming the line where one cannot be read.
pub fn parse_csv(text: &str) -> Result<Vec<Row>> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| crate::Error::Invalid(format!("report.csv: no column {name}")))
    };
    let named = |v: &str, known: &[&'static str], what: &str| {
        known
            .iter()
            .copied()
            .find(|k| *k == v)
            .ok_or_else(|| crate::Error::Invalid(format!("report.csv: unknown {what} {v:?}")))
    };
    let techniques: Vec<&'static str> = every_technique()
        .iter()
        .map(|t| t.name())
        .chain([super::cubes::PEER])
        .collect();
    let kinds = ["soft", "sun", "studio", "interior"];
    let references = [
        Reference::ExactGpu,
        Reference::ExactHost,
        Reference::MonteCarlo,
        Reference::PixelAreaMean,
    ]
    .map(Reference::name);
    let mut rows = Vec::new();
    for (k, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let at = |name: &str| -> Result<&str> {
            f.get(col(name)?).copied().ok_or_else(|| {
                crate::Error::Invalid(format!("report.csv line {}: too few fields", k + 2))
            })
        };
        let num = |name: &str| -> Result<f64> {
            at(name)?.parse::<f64>().map_err(|_| {
                crate::Error::Invalid(format!("report.csv line {}: {name} is not a number", k + 2))
            })
        };
        rows.push(Row {
            probe: at("probe")?.to_string(),
            kind: named(at("probe_kind")?, &kinds, "probe kind")?,
            material: at("material")?.to_string(),
            technique: named(at("technique")?, &techniques, "technique")?,
            params: at("params")?.to_string(),
            rms: num("relative_rms")?,
            bias: num("mean_bias")?,
            tile: num("worst_tile")?,
            gpu_ms: num("gpu_ms")?,
            pre_ms: num("precompute_gpu_ms")?,
            wall_s: num("render_wall_s")?,
            process_s: num("process_s")?,
            noise: num("reference_noise")?,
            twin: num("reference_twin_error")?,
            reference: named(at("reference")?, &references, "reference")?,
            frame_ms: num("changing_frame_gpu_ms")?,
            frame_rms: num("changing_frame_relative_rms")?,
        });
    }
    Ok(rows)
}

/// report.csv: a row per measurement.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "technique,params,probe,probe_kind,material,relative_rms,mean_bias,worst_tile,gpu_ms,precompute_gpu_ms,render_wall_s,process_s,reference,reference_noise,reference_twin_error,changing_frame_gpu_ms,changing_frame_relative_rms\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.6e},{:.6e},{:.6e},{:.4},{:.4},{:.4},{:.4},{},{:.3e},{:.3e},{:.4},{:.6e}",
            r.technique,
            r.params,
            r.probe,
            r.kind,
            r.material,
            r.rms,
            r.bias,
            r.tile,
            r.gpu_ms,
            r.pre_ms,
            r.wall_s,
            r.process_s,
            r.reference,
            r.noise,
            r.twin,
            r.frame_ms,
            r.frame_rms
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spheres drawn together: each cell's pixels see their own sphere, with the normal the
    /// one camera sees on the one sphere (to 1e-12), and the same pixels miss (an odd and an
    /// even count; a layout off by half a cell fails).
    #[test]
    fn each_cell_sees_its_sphere_as_alone() {
        use crate::math::camera::trace;
        let cam = sphere_camera(16);
        let one = scene(
            cam,
            Brdf::Lambert,
            Technique::Sh { order: 2 },
            None,
            1,
            Default::default(),
        );
        let alone: Vec<_> = one.objects.iter().map(|o| o.shape).collect();
        for n in [2usize, 3] {
            let brdfs = vec![Brdf::Lambert; n];
            let sc = group_scene(&one, &brdfs).unwrap();
            assert_eq!((sc.camera.width, sc.camera.height), (16 * n as u32, 16));
            let shapes: Vec<_> = sc.objects.iter().map(|o| o.shape).collect();
            for k in 0..n {
                for j in 0..16 {
                    for i in 0..16 {
                        let (o, d) = cam.ray(i, j);
                        let want = trace(&alone, o, d);
                        let (o, d) = sc.camera.ray(i + 16 * k as u32, j);
                        let got = trace(&shapes, o, d);
                        match (want, got) {
                            (None, None) => {}
                            (Some(w), Some(g)) => {
                                assert_eq!(g.index, k, "cell {k} pixel ({i}, {j})");
                                assert!((w.normal - g.normal).length() < 1e-12);
                            }
                            (w, g) => panic!("n {n} cell {k} ({i}, {j}): {w:?} vs {g:?}"),
                        }
                    }
                }
            }
        }
    }

    /// report.csv read back is the rows written (to the digits the CSV keeps), and a row that
    /// names what no report writes is refused by line.
    #[test]
    fn csv_reads_back_what_it_wrote() {
        let row = Row {
            probe: "quarry_01_1k".into(),
            kind: "sun",
            material: "ggx 0.05".into(),
            technique: "fis",
            params: "N=64 (no lights)".into(),
            rms: 0.0123,
            bias: -0.0004,
            tile: 0.05,
            gpu_ms: 12.5,
            pre_ms: 10.25,
            wall_s: 0.5,
            process_s: 0.75,
            noise: 0.0,
            twin: 2.5e-7,
            reference: Reference::ExactGpu.name(),
            frame_ms: 30.0,
            frame_rms: 0.0125,
        };
        let mirror = Row {
            material: "mirror".into(),
            technique: "lookup",
            params: "point".into(),
            reference: Reference::PixelAreaMean.name(),
            ..row.clone()
        };
        let text = csv(&[row.clone(), mirror]);
        let back = parse_csv(&text).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(csv(&back), text);
        assert_eq!(
            (back[0].label(), back[1].reference),
            (row.label(), "pixel-area mean")
        );
        let bad = text.replace("fis,", "nonsense,");
        let e = parse_csv(&bad).unwrap_err().to_string();
        assert!(e.contains("unknown technique \"nonsense\""), "{e}");
    }
}
