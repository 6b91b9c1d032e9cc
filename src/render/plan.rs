//! A render's plan: what a scene asks of the GPU, resolved once. The passes it runs and why,
//! each object's technique and the lights it reads, the paraboloid's size and conversion, the
//! SH order, the SH-BRDF tables, the split-sum chain, the Monte Carlo budget and the shade
//! pipeline's code. The render's stages read this plan and never the scene's materials;
//! `envlight plan` prints it.

use crate::abi::{split_sum, ShaderId};
use crate::math::brdf::Brdf;
use crate::math::envmap::EnvMap;
use crate::math::lights::{lobe_scale, ExtractOptions};
use crate::math::sh_brdf::ViewGrid;
use crate::math::Mapping;
use crate::passes::gbuffer::brdf_bits;
use crate::passes::shade::ShadeCode;
use crate::passes::{ConvertOptions, ShBrdfProjector};
use crate::scene::{
    LightsMode, LookupFilter, MapShape, Scene, SceneObject, SplitSumSettings, Technique,
};

/// What a render will run, resolved from a scene and its environment once.
#[derive(Clone, Debug)]
pub struct Plan {
    /// GPU passes, in order (a pass appears once however many times it runs).
    pub passes: Vec<PlannedPass>,
    /// Remarks: CPU work, and effects a technique leaves out.
    pub notes: Vec<String>,
    /// Each object's technique and what it reads, in the scene's order.
    pub objects: Vec<ObjectPlan>,
    /// The SH order projected: the highest any object reads (2 where none does).
    pub lmax: u32,
    /// The conversion to the dual paraboloid, where FIS, split-sum or footprint lookups read
    /// its MIP chain.
    pub dp: Option<ConvertOptions>,
    /// The lights extracted from the environment, and who adds them back.
    pub lights: LightsPlan,
    /// The SH-BRDF tables: one per SH-BRDF object, concatenated.
    pub tables: Vec<TablePlan>,
    /// The split-sum chain and its DFG tables, where an object uses split-sum.
    pub split: Option<SplitPlan>,
    /// Monte Carlo samples per pixel and error target, where an object uses the reference.
    pub mc: Option<(u32, Option<f64>)>,
    /// The shade pipeline the draw takes: known before any input exists, so that it builds
    /// while the inputs are made.
    pub code: ShadeCode,
}

/// One planned pass and why.
#[derive(Clone, Debug)]
pub struct PlannedPass {
    /// Which.
    pub kind: PassKind,
    /// Why the scene needs it.
    pub why: String,
}

/// One object's part of the plan.
#[derive(Clone, Copy, Debug)]
pub struct ObjectPlan {
    /// Its technique (the material's, or its BRDF's default).
    pub technique: Technique,
    /// Its BRDF.
    pub brdf: Brdf,
    /// Whether it reads the dual-paraboloid chain (FIS, split-sum).
    pub on_chain: bool,
    /// Its lobe's angular scale, where the BRDF has one (`lobe_scale`).
    pub lobe: Option<f64>,
    /// Offset of its SH-BRDF table in the concatenated tables, in floats (0 for others).
    pub table_offset: u32,
}

impl ObjectPlan {
    /// The plan of object `o`; `table_offset` is where its SH-BRDF table would start.
    pub fn of(o: &SceneObject, table_offset: u32) -> ObjectPlan {
        let technique = o.material.technique();
        ObjectPlan {
            technique,
            brdf: o.material.kind,
            on_chain: matches!(technique, Technique::Fis { .. } | Technique::SplitSum),
            lobe: lobe_scale(&o.material.kind),
            table_offset: match technique {
                Technique::ShBrdf { .. } => table_offset,
                _ => 0,
            },
        }
    }

    /// A prefiltered irradiance map (a Lambertian object).
    pub fn diffuse_prefiltered(&self) -> bool {
        matches!(self.technique, Technique::Prefiltered { .. })
            && matches!(self.brdf, Brdf::Lambert)
    }

    /// A prefiltered Phong map.
    pub fn phong_prefiltered(&self) -> bool {
        matches!(self.technique, Technique::Prefiltered { .. })
            && matches!(self.brdf, Brdf::Phong { .. })
    }
}

/// Which extractions a render makes and which objects may add the lights back. Whether they
/// do depends on what the extraction finds (see the render's lights stage).
#[derive(Clone, Copy, Debug, Default)]
pub struct LightsPlan {
    /// The chain's extraction: its residual feeds the paraboloid and prefiltered Phong maps,
    /// its light texels are added under each lobe.
    pub chain: Option<ExtractOptions>,
    /// The diffuse extraction: deeper, its texels summed by clusters for SH and irradiance
    /// maps.
    pub diffuse: Option<ExtractOptions>,
    /// The paraboloid may hold the residual: lights are extracted, the chain is read (FIS,
    /// split-sum, footprint lookups) and every lobe on it has a known scale.
    pub dp: bool,
    /// SH irradiance objects add the clusters' irradiance.
    pub sh: bool,
    /// Prefiltered irradiance maps add it.
    pub prefiltered: bool,
    /// Prefiltered Phong maps add the light texels under their lobes.
    pub phong: bool,
    /// The finest lobe on the chain the light texels' nodes must resolve.
    pub finest_chain: f64,
}

/// One SH-BRDF table.
#[derive(Clone, Copy, Debug)]
pub struct TablePlan {
    /// The BRDF projected.
    pub brdf: Brdf,
    /// Its SH order.
    pub order: u32,
    /// The view directions it is tabulated at.
    pub grid: ViewGrid,
    /// Its offset in the concatenated tables, in floats.
    pub offset: u32,
}

/// The split-sum chain.
#[derive(Clone, Debug)]
pub struct SplitPlan {
    /// The chain's side ([`split_size`]).
    pub size: u32,
    /// One DFG table per Smith form in use (`true`: height-correlated), in this order.
    pub forms: Vec<bool>,
}

impl Plan {
    /// The pass kinds, in order.
    pub fn kinds(&self) -> Vec<PassKind> {
        self.passes.iter().map(|p| p.kind).collect()
    }

    /// Whether the plan runs pass `kind`.
    pub fn runs(&self, kind: PassKind) -> bool {
        self.passes.iter().any(|p| p.kind == kind)
    }

    /// The plan's resolved settings, a line each: the paraboloid, the SH order, the lights
    /// extracted, each object's technique, the split-sum chain and the Monte Carlo budget.
    pub fn settings(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(d) = &self.dp {
            let reads = if d.nearest { "texel means" } else { "bilinear" };
            v.push(format!("paraboloid: {0}² a disc ({reads})", d.size));
        }
        if self.runs(PassKind::ShProjection) {
            v.push(format!("sh: order {}", self.lmax));
        }
        let l = &self.lights;
        let mut lights = Vec::new();
        if l.chain.is_some() {
            lights.push("for the chain and Phong maps");
        }
        if l.diffuse.is_some() {
            lights.push("clustered for SH and irradiance maps");
        }
        if !lights.is_empty() {
            v.push(format!("lights: extracted {}", lights.join("; ")));
        }
        for (k, o) in self.objects.iter().enumerate() {
            v.push(format!(
                "object {k}: {} by {:?}",
                kind_name(&o.brdf),
                o.technique
            ));
        }
        if let Some(s) = &self.split {
            v.push(format!(
                "split-sum: chain {}², {} DFG table(s)",
                s.size,
                s.forms.len()
            ));
        }
        if let Some((samples, error)) = self.mc {
            v.push(format!(
                "monte carlo: up to {samples} spp, error target {error:?}"
            ));
        }
        v
    }

    /// Floats in the concatenated SH-BRDF tables.
    pub fn table_floats(&self) -> usize {
        self.tables
            .iter()
            .map(|t| ShBrdfProjector::table_floats(t.order, t.grid))
            .sum()
    }
}

/// Plans a render of `scene` lit by `env` (its mapping and size; the texels are not read).
pub fn plan(scene: &Scene, env: &EnvMap) -> Plan {
    plan_for(scene, MapShape::of(env))
}

/// Plans a render of `scene` lit by an environment of shape `env`.
pub fn plan_for(scene: &Scene, env: MapShape) -> Plan {
    let objects = object_plans(scene);
    let users = Users::of(scene);
    let passes = passes(scene, &users, env.mapping);
    let runs = |k: PassKind| passes.iter().any(|p| p.kind == k);
    let lmax = objects
        .iter()
        .filter_map(|o| match o.technique {
            Technique::Sh { order } | Technique::ShBrdf { order, .. } => Some(order),
            _ => None,
        })
        .max()
        .unwrap_or(2);
    let dp = runs(PassKind::DualParaboloid).then(|| dp_convert_options(scene, env));
    let split = runs(PassKind::SplitSum).then(|| {
        let dp_size = dp.map(|d| d.size).unwrap_or(split_sum::DEFAULT_SIZE);
        let mut forms: Vec<bool> = Vec::new();
        for o in &objects {
            if let (Technique::SplitSum, Brdf::Ggx { correlated, .. }) = (o.technique, o.brdf) {
                if !forms.contains(&correlated) {
                    forms.push(correlated);
                }
            }
        }
        SplitPlan {
            size: split_size(&scene.split_sum, dp_size),
            forms,
        }
    });
    let tables = objects
        .iter()
        .filter_map(|o| match o.technique {
            Technique::ShBrdf { order, grid, .. } => Some(TablePlan {
                brdf: o.brdf,
                order,
                grid: ViewGrid { size: grid },
                offset: o.table_offset,
            }),
            _ => None,
        })
        .collect();
    let mut p = Plan {
        notes: notes(scene, &users, &passes),
        lights: lights_plan(scene, &objects, &passes),
        passes,
        lmax,
        dp,
        tables,
        split,
        mc: mc_budget(&objects),
        code: ShadeCode::default(),
        objects,
    };
    p.code = shade_code(scene, &p);
    p
}

/// Each object's technique, BRDF, lobe scale and SH-BRDF table offset.
fn object_plans(scene: &Scene) -> Vec<ObjectPlan> {
    let mut table_floats = 0usize;
    scene
        .objects
        .iter()
        .map(|o| {
            let p = ObjectPlan::of(o, table_floats as u32);
            if let Technique::ShBrdf { order, grid, .. } = p.technique {
                table_floats += ShBrdfProjector::table_floats(order, ViewGrid { size: grid });
            }
            p
        })
        .collect()
}

/// Monte Carlo: one accumulation for every MC material, at the most samples any asks and the
/// tightest error target.
fn mc_budget(objects: &[ObjectPlan]) -> Option<(u32, Option<f64>)> {
    objects
        .iter()
        .filter_map(|o| match o.technique {
            Technique::Mc { samples, error } => Some((samples, error)),
            _ => None,
        })
        .reduce(|(s, e), (s2, e2)| {
            (
                s.max(s2),
                match (e, e2) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                },
            )
        })
}

/// Which extractions the render makes. SH and prefiltered diffuse objects take the diffuse
/// residual's SH or irradiance map plus its light clusters' irradiance (a deep extraction,
/// summed by cells); FIS and split-sum objects the residual's paraboloid plus the light
/// texels under their lobes, prefiltered Phong objects the residual's Phong map plus the
/// light texels under their BRDF.
fn lights_plan(scene: &Scene, objects: &[ObjectPlan], passes: &[PlannedPass]) -> LightsPlan {
    let runs = |k: PassKind| passes.iter().any(|p| p.kind == k);
    let extracting = scene.environment.lights == LightsMode::Extract;
    let has = |f: &dyn Fn(&ObjectPlan) -> bool| objects.iter().any(f);
    let sh = extracting
        && runs(PassKind::ShProjection)
        && has(&|o| matches!(o.technique, Technique::Sh { .. }));
    let prefiltered =
        extracting && runs(PassKind::Prefilter) && has(&ObjectPlan::diffuse_prefiltered);
    let phong = extracting && runs(PassKind::Prefilter) && has(&ObjectPlan::phong_prefiltered);
    let dp = runs(PassKind::DualParaboloid) && chain_takes_lights(scene);
    // The filled residual serves filtered sampling and prefiltered Phong maps, which read it
    // bilinearly, where a clamped residual's holes darken the lobe; footprint lookups alone
    // keep the clamp, since they take light texels by shares linearised over the pixel,
    // which a fill would count twice.
    let chain = (dp || phong).then(|| {
        let mut o = scene.environment.extract_options();
        if !has(&|o| o.on_chain) && !phong {
            o.fill = None;
        }
        o
    });
    LightsPlan {
        chain,
        diffuse: (sh || prefiltered).then(|| scene.environment.diffuse_extract_options()),
        dp,
        sh,
        prefiltered,
        phong,
        finest_chain: objects
            .iter()
            .filter(|o| o.on_chain)
            .filter_map(|o| o.lobe)
            .fold(1.0, f64::min),
    }
}

/// The objects of each technique, as the plan's reasons name them ("0 (ggx)").
struct Users {
    fis: Vec<String>,
    sh: Vec<String>,
    pre: Vec<String>,
    mc: Vec<String>,
    lookup: Vec<String>,
    sh_brdf: Vec<String>,
    split: Vec<String>,
}

impl Users {
    fn of(scene: &Scene) -> Users {
        let users = |f: &dyn Fn(&Technique) -> bool| -> Vec<String> {
            scene
                .objects
                .iter()
                .enumerate()
                .filter(|(_, o)| f(&o.material.technique()))
                .map(|(k, o)| format!("{k} ({})", kind_name(&o.material.kind)))
                .collect()
        };
        Users {
            fis: users(&|t| matches!(t, Technique::Fis { .. })),
            sh: users(&|t| matches!(t, Technique::Sh { .. })),
            pre: users(&|t| matches!(t, Technique::Prefiltered { .. })),
            mc: users(&|t| matches!(t, Technique::Mc { .. })),
            lookup: users(&|t| matches!(t, Technique::Lookup)),
            sh_brdf: users(&|t| matches!(t, Technique::ShBrdf { .. })),
            split: users(&|t| matches!(t, Technique::SplitSum)),
        }
    }
}

/// The GPU passes a render of `scene` runs, in order, each with its reason; `source` is the
/// environment file's mapping (Monte Carlo samples a lat-long map).
fn passes(scene: &Scene, users: &Users, source: Mapping) -> Vec<PlannedPass> {
    let Users {
        fis,
        sh,
        pre,
        mc,
        lookup,
        sh_brdf,
        split,
    } = users;
    let mut passes = Vec::new();
    let list = |v: &[String]| v.join(", ");
    if !sh.is_empty() || !sh_brdf.is_empty() {
        let mut why = Vec::new();
        if !sh.is_empty() {
            why.push(format!("objects {} use SH irradiance", list(sh)));
        }
        if !sh_brdf.is_empty() {
            why.push(format!("objects {} use SH-BRDF shading", list(sh_brdf)));
        }
        passes.push(PlannedPass {
            kind: PassKind::ShProjection,
            why: why.join("; "),
        });
    }
    if !sh_brdf.is_empty() {
        passes.push(PlannedPass {
            kind: PassKind::ShBrdfTable,
            why: format!(
                "objects {} need their BRDF's SH vector per view direction",
                list(sh_brdf)
            ),
        });
    }
    let filter = scene.environment.filter;
    let footprint_mirrors = filter != LookupFilter::Point && !lookup.is_empty();
    if !fis.is_empty()
        || !split.is_empty()
        || footprint_mirrors
        || filter == LookupFilter::Footprint
    {
        let mut why = Vec::new();
        if footprint_mirrors {
            why.push(format!(
                "objects {} are mirrors filtered over each pixel's footprint",
                list(lookup)
            ));
        }
        if filter == LookupFilter::Footprint {
            why.push("the background is filtered over each pixel's footprint".into());
        }
        if !fis.is_empty() {
            why.push(format!(
                "objects {} use filtered importance sampling",
                list(fis)
            ));
        }
        if !split.is_empty() {
            why.push(format!(
                "objects {} use split-sum, whose chain is prefiltered by FIS",
                list(split)
            ));
        }
        passes.push(PlannedPass {
            kind: PassKind::DualParaboloid,
            why: why.join("; "),
        });
        passes.push(PlannedPass {
            kind: PassKind::MipChain,
            why: if fis.is_empty() && split.is_empty() {
                "footprint lookups read the MIP level of their taps' spacing".into()
            } else {
                "FIS reads each sample at the MIP level its pdf calls for".into()
            },
        });
    }
    if !split.is_empty() {
        passes.push(PlannedPass {
            kind: PassKind::SplitSum,
            why: format!(
                "objects {} read a GGX chain prefiltered per roughness (n = v = r) and a DFG table",
                list(split)
            ),
        });
    }
    if !pre.is_empty() {
        passes.push(PlannedPass {
            kind: PassKind::Prefilter,
            why: format!(
                "objects {} use prefiltered maps (brute force, once per distinct map)",
                list(pre)
            ),
        });
    }
    passes.push(PlannedPass {
        kind: PassKind::GBuffer,
        why: "every render casts its camera rays".into(),
    });
    if !mc.is_empty() {
        if source != Mapping::LatLong {
            passes.push(PlannedPass {
                kind: PassKind::LatLong,
                why: "Monte Carlo samples a lat-long map by its luminance".into(),
            });
        }
        passes.push(PlannedPass {
            kind: PassKind::MonteCarlo,
            why: format!("objects {} use the Monte Carlo reference", list(mc)),
        });
    }
    passes.push(PlannedPass {
        kind: PassKind::Shade,
        why: "shades every pixel and shows the environment behind".into(),
    });
    passes
}

/// Remarks on a render of `scene` running `passes`: CPU work, and what shadows leave out.
fn notes(scene: &Scene, users: &Users, passes: &[PlannedPass]) -> Vec<String> {
    let Users {
        fis,
        sh,
        pre,
        mc,
        lookup,
        sh_brdf,
        split,
    } = users;
    let mut notes = Vec::new();
    if !mc.is_empty() {
        notes.push("CPU: the luminance CDF of the lat-long map, for environment sampling".into());
    }
    if scene.shadows {
        let mut traced = Vec::new();
        if !lookup.is_empty() {
            traced.push("mirror lookups");
        }
        if !fis.is_empty() {
            traced.push("FIS samples");
        }
        if !mc.is_empty() {
            traced.push("Monte Carlo samples");
        }
        notes.push(format!(
            "shadows: {} trace visibility against the scene's objects{}",
            if traced.is_empty() {
                "nothing".to_string()
            } else {
                traced.join(", ")
            },
            if sh.is_empty() && pre.is_empty() && sh_brdf.is_empty() && split.is_empty() {
                String::new()
            } else {
                "; SH, split-sum and prefiltered maps integrate the whole environment and stay unshadowed"
                    .into()
            }
        ));
    }
    if !passes.iter().any(|p| p.kind == PassKind::MipChain) {
        notes.push(
            "no dual paraboloid or MIP chain: no material uses FIS, split-sum or footprint lookups"
                .into(),
        );
    }
    notes
}

/// A GPU pass a render may run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PassKind {
    /// Ray casting the objects.
    GBuffer,
    /// Converting the environment to a dual paraboloid.
    DualParaboloid,
    /// Its MIP chain.
    MipChain,
    /// SH projection.
    ShProjection,
    /// SH projection of BRDFs per view (SH-BRDF tables).
    ShBrdfTable,
    /// Split-sum: the prefiltered GGX chain and the DFG tables.
    SplitSum,
    /// Brute-force prefiltering of one map.
    Prefilter,
    /// Converting the environment to lat-long for Monte Carlo sampling.
    LatLong,
    /// Monte Carlo frames.
    MonteCarlo,
    /// Light extraction on the GPU (the resident path's: band 0, extraction, clusters, the
    /// residual's SH).
    Lights,
    /// Shading and compositing.
    Shade,
}

impl PassKind {
    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            PassKind::GBuffer => "gbuffer",
            PassKind::DualParaboloid => "dual paraboloid",
            PassKind::MipChain => "mip chain",
            PassKind::ShProjection => "sh projection",
            PassKind::ShBrdfTable => "sh brdf table",
            PassKind::SplitSum => "split-sum",
            PassKind::Prefilter => "prefilter",
            PassKind::LatLong => "lat-long",
            PassKind::MonteCarlo => "monte carlo",
            PassKind::Lights => "light extraction",
            PassKind::Shade => "shade",
        }
    }

    /// The shader modules whose pipelines the pass creates (either of a pair where the
    /// device decides: cube or 2D sources, subgroups or shared memory, shade with or
    /// without vote, whole or for the scene's one technique).
    pub fn pipelines(self) -> Vec<&'static str> {
        self.shader_ids().iter().map(|id| id.name()).collect()
    }

    /// [`PassKind::pipelines`] as the shader table's ids.
    pub(crate) fn shader_ids(self) -> &'static [ShaderId] {
        use ShaderId::*;
        match self {
            PassKind::GBuffer => &[GBuffer],
            // A lat-long source takes exact footprint areas (slopes, then areas).
            PassKind::DualParaboloid => &[
                Convert2d,
                ConvertCube,
                ConvertSlopes,
                ConvertAreaParaboloid,
                ConvertAreaFastParaboloid,
                ConvertAreaListParaboloid,
                ConvertAreaRim,
                ConvertPlanned,
            ],
            PassKind::LatLong => &[Convert2d, ConvertCube],
            PassKind::MipChain => &[Mip],
            PassKind::ShProjection => &[
                ShProjectSubgroup,
                ShProjectGridSubgroup,
                ShRowsSubgroup,
                ShLatLongSubgroup,
                ShReduceSubgroup,
                ShProjectShared,
                ShProjectGridShared,
                ShRowsShared,
                ShLatLongShared,
                ShReduceShared,
                ShPack,
            ],
            PassKind::ShBrdfTable => &[ShBrdf],
            PassKind::SplitSum => &[Dfg, PrefilterGgx],
            PassKind::Prefilter => &[BrutePrepare, BruteTiles, Brute, BruteResolve],
            PassKind::MonteCarlo => &[Mc],
            PassKind::Lights => &[
                Extract,
                ExtractGrow,
                ExtractSelect,
                ExtractClusters,
                ExtractPrepare,
            ],
            PassKind::Shade => &crate::passes::shade::MODULES,
        }
    }
}

fn kind_name(k: &Brdf) -> &'static str {
    match k {
        Brdf::Mirror => "mirror",
        Brdf::Lambert => "diffuse",
        Brdf::Phong { .. } => "phong",
        Brdf::Blinn { .. } => "blinn",
        Brdf::Ggx { .. } => "ggx",
        Brdf::Ward { .. } => "ward",
    }
}

/// Side of the split-sum chain: the scene's, or the FIS paraboloid's up to
/// `split_sum::DEFAULT_SIZE`, but at least enough that the coarsest of `levels` keeps
/// `split_sum::MIN_LEVEL_SIZE` texels a side.
pub fn split_size(settings: &SplitSumSettings, dp_size: u32) -> u32 {
    settings.size.unwrap_or_else(|| {
        dp_size
            .min(split_sum::DEFAULT_SIZE)
            .max(split_sum::MIN_LEVEL_SIZE << settings.levels.saturating_sub(1))
    })
}

/// How `scene`'s FIS dual paraboloid is converted from `env`: [`fis_dp_size`], nearest reads
/// where [`chain_of_texel_means`], and the residual's edge points and sampling rate
/// (`ConvertOptions::for_residual_chain`) where the chain is to take the lights
/// ([`chain_takes_lights`]; the record takes the defaults where the lights found are too
/// small for its lobes' quadrature and so stay in the chain).
fn dp_convert_options(scene: &Scene, env: MapShape) -> ConvertOptions {
    let size = scene.fis_dp_size(env);
    let opts = ConvertOptions::new(Mapping::DualParaboloid, size)
        .with_orientation(scene.environment.orientation())
        .with_nearest(scene.chain_of_texel_means());
    match chain_takes_lights(scene) {
        true => opts.for_residual_chain((env.mapping, env.width, env.height)),
        false => opts,
    }
}

/// Whether `scene`'s dual-paraboloid chain is to hold the residual of extracted lights, the
/// light texels added by the shader: lights extracted, the chain read by FIS, split-sum or
/// footprint lookups, and every chain object's lobe of a known scale (the extraction may still
/// find no light, or none its lobes' quadrature resolves).
fn chain_takes_lights(scene: &Scene) -> bool {
    let on_chain = |o: &crate::scene::SceneObject| {
        matches!(
            o.material.technique(),
            Technique::Fis { .. } | Technique::SplitSum
        )
    };
    // Footprint lookups read the chain too, and add the light texels they cover.
    let footprint_reads = scene.environment.filter != LookupFilter::Point;
    scene.environment.lights == LightsMode::Extract
        && (scene.objects.iter().any(on_chain) || footprint_reads)
        && !scene
            .objects
            .iter()
            .any(|o| on_chain(o) && lobe_scale(&o.material.kind).is_none())
}

/// The shade code `scene`'s draw takes under `plan`: known before any input exists, so that
/// its pipeline builds while the inputs are made.
fn shade_code(scene: &Scene, plan: &Plan) -> ShadeCode {
    let needs = |k: PassKind| plan.runs(k);
    let fis = needs(PassKind::DualParaboloid);
    ShadeCode {
        fis,
        sh: needs(PassKind::ShProjection),
        prefiltered: needs(PassKind::Prefilter),
        mc: needs(PassKind::MonteCarlo),
        sh_brdf: needs(PassKind::ShBrdfTable),
        split_sum: needs(PassKind::SplitSum),
        footprint: {
            let f = scene.footprint(fis, false);
            f.mirror || f.background
        },
        shadows: scene.shadows,
        brdfs: brdf_bits(scene.objects.iter().map(|o| o.material.kind.id())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_passes_and_resolves_each_object() {
        let s = Scene::parse(crate::scene::GLOSSY_TEST_SCENE).unwrap();
        let env = EnvMap::new(Mapping::LatLong, 64, 32, vec![[1.0; 3]; 64 * 32]);
        let p = plan(&s, &env);
        assert_eq!(
            p.kinds(),
            vec![
                PassKind::ShProjection,
                PassKind::DualParaboloid,
                PassKind::MipChain,
                PassKind::GBuffer,
                PassKind::Shade
            ]
        );
        // The diffuse plane's default technique is SH of order 2; the sphere reads the chain.
        assert_eq!(p.lmax, 2);
        assert!(p.objects[0].on_chain && !p.objects[1].on_chain);
        assert_eq!(p.objects[1].technique, Technique::Sh { order: 2 });
        assert_eq!(
            p.dp.map(|d| d.size),
            Some(s.fis_dp_size(MapShape::of(&env)))
        );
        assert!(p.code.fis && p.code.sh && !p.code.mc);
        assert!(p.split.is_none() && p.mc.is_none() && p.tables.is_empty());
    }

    /// A cube's residual converts to the chain's paraboloid at the chain's rate; a lat-long
    /// map by areas (no sample count), and a map whose lights stay in the chain at the
    /// general rate.
    #[test]
    fn the_residual_of_a_cube_converts_at_the_chains_rate() {
        let s = Scene::parse(crate::scene::GLOSSY_TEST_SCENE).unwrap();
        let cube = MapShape {
            mapping: Mapping::Cube,
            width: 256,
            height: 256,
        };
        let size = s.fis_dp_size(cube);
        let want = crate::passes::Converter::chain_supersampling((Mapping::Cube, 256, 256), size);
        assert!(chain_takes_lights(&s));
        assert_eq!(dp_convert_options(&s, cube).supersample, Some(want));
        let latlong = MapShape {
            mapping: Mapping::LatLong,
            width: 512,
            height: 256,
        };
        assert_eq!(dp_convert_options(&s, latlong).supersample, None);
        let mut whole = s.clone();
        whole.environment.lights = LightsMode::None;
        assert_eq!(dp_convert_options(&whole, cube).supersample, None);
    }
}
