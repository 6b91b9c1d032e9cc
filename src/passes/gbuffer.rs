//! The G-buffer: analytic spheres and planes ray cast per pixel by a fullscreen fragment pass
//! (`glsl/gbuffer.frag`, float64 twin `crate::math::camera`). Shading passes read it: SH
//! diffuse shading here, glossy techniques later, all from the same three images.

use super::map::GpuEnvMap;
use crate::abi::{binding, brdf::technique, object, push::GBufferPush, ShaderId};
use crate::error::Result;
use crate::gpu::{Bind, Buffer, Context, ImageDesc, Pipeline, Recorder, Timed};
use crate::math::brdf::Brdf;
use crate::math::camera::{Camera, Projection, Shape};
use crate::math::Mapping;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;

/// Format of the G-buffer images and of shaded frames.
pub const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Usage of the G-buffer images and of shaded frames: drawn, sampled, copied out; and, where
/// the tests may poison what a pass draws (feature `test-hooks`), written as storage.
pub const TARGET_USAGE: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(
    vk::ImageUsageFlags::COLOR_ATTACHMENT.as_raw()
        | vk::ImageUsageFlags::SAMPLED.as_raw()
        | vk::ImageUsageFlags::TRANSFER_SRC.as_raw()
        | if cfg!(feature = "test-hooks") {
            vk::ImageUsageFlags::STORAGE.as_raw()
        } else {
            0
        },
);

pub use crate::abi::record::ObjectRecord;

// SAFETY: repr(C), u32/f32 fields and arrays of them only, no padding (asserted where the
// record is declared, crate::abi::record).
unsafe impl bytemuck::Zeroable for ObjectRecord {}
// SAFETY: as above; every bit pattern is a valid record.
unsafe impl bytemuck::Pod for ObjectRecord {}

/// How the shade pass shades an object: its technique, and where that technique's data sits
/// in the buffers the render binds ([`crate::passes::shade::ShadeInputs`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// One lookup of the reflected direction (a mirror).
    Lookup,
    /// Filtered importance sampling.
    Fis {
        /// Samples a pixel.
        samples: u32,
        /// Added to each sample's lod.
        lod_bias: f32,
        /// Whether the sample set turns per pixel.
        rotate: bool,
        /// With lights extracted (the chain holds the residual): the lobe's angular scale,
        /// under which the light texels are added.
        lights: Option<f32>,
    },
    /// SH irradiance (diffuse).
    Sh {
        /// The coefficients' first index.
        offset: u32,
        /// Their order lmax.
        order: u32,
        /// Whether they are the residual's, the light clusters added.
        lights: bool,
    },
    /// A prefiltered lat-long map: irradiance by the normal (Lambert), Phong by r.
    Prefiltered {
        /// The map's first texel.
        offset: u32,
        /// The map's width.
        width: u32,
        /// With lights extracted (the map is the residual's): for a Phong map, the lobe's
        /// scale under which the light texels are added; for irradiance, any value (the
        /// light clusters are added).
        lights: Option<f32>,
    },
    /// The Monte Carlo reference's accumulation.
    Mc,
    /// SH shading of the BRDF (Kautz et al.).
    ShBrdf {
        /// The BRDF table's view grid side.
        grid: u32,
        /// The environment's coefficients' first index.
        offset: u32,
        /// The order lmax.
        order: u32,
        /// The BRDF table's first float.
        table: u32,
    },
    /// Split-sum: the prefiltered chain times the DFG table.
    SplitSum {
        /// The chain's last lod (its levels − 1).
        last_lod: f32,
        /// The DFG table's first entry.
        dfg_offset: u32,
        /// The DFG table's side.
        dfg_size: u32,
        /// The lobe's taps a pixel (below 2: one lookup along r).
        taps: u32,
        /// With lights extracted: 1/∫K at the material's α.
        lights: Option<f32>,
    },
}

/// The shape part of a record (material and technique fields zero).
pub fn shape_record(shape: &Shape) -> ObjectRecord {
    match *shape {
        Shape::Sphere { center, radius } => ObjectRecord {
            shape: [
                center[0] as f32,
                center[1] as f32,
                center[2] as f32,
                radius as f32,
            ],
            kind: object::SPHERE,
            ..Default::default()
        },
        Shape::Plane {
            normal,
            offset,
            extent,
        } => {
            let n = glam::DVec3::from(normal).normalize();
            ObjectRecord {
                shape: [n.x as f32, n.y as f32, n.z as f32, offset as f32],
                kind: object::PLANE,
                extent: extent as f32,
                ..Default::default()
            }
        }
    }
}

/// The record of an object: `shape`, its colour `albedo` (diffuse albedo or specular colour)
/// under `brdf`, shaded as `shading` says.
pub fn object_record(
    shape: &Shape,
    albedo: [f64; 3],
    brdf: &Brdf,
    shading: Shading,
) -> ObjectRecord {
    let params = brdf.params();
    let mut g = ObjectRecord {
        albedo: [albedo[0] as f32, albedo[1] as f32, albedo[2] as f32, 0.0],
        brdf: brdf.id(),
        params: [params[0] as f32, params[1] as f32],
        ..shape_record(shape)
    };
    let lights = |on: bool| if on { object::LIGHTS } else { 0 };
    match shading {
        Shading::Lookup => g.technique = technique::LOOKUP,
        Shading::Mc => g.technique = technique::MC,
        Shading::Fis {
            samples,
            lod_bias,
            rotate,
            lights: lobe,
        } => {
            g.technique = technique::FIS;
            g.samples = samples;
            g.lod_bias = lod_bias;
            g.lobe = lobe.unwrap_or(0.0);
            g.flags = lights(lobe.is_some()) | if rotate { object::ROTATE } else { 0 };
        }
        Shading::Sh {
            offset,
            order,
            lights: on,
        } => {
            g.technique = technique::SH;
            (g.data_offset, g.size, g.flags) = (offset, order, lights(on));
        }
        Shading::Prefiltered {
            offset,
            width,
            lights: lobe,
        } => {
            g.technique = technique::PREFILTERED;
            (g.data_offset, g.size) = (offset, width);
            g.lobe = lobe.unwrap_or(0.0);
            g.flags = lights(lobe.is_some());
        }
        Shading::ShBrdf {
            grid,
            offset,
            order,
            table,
        } => {
            g.technique = technique::SH_BRDF;
            (g.grid, g.data_offset, g.size, g.table_offset) = (grid, offset, order, table);
        }
        Shading::SplitSum {
            last_lod,
            dfg_offset,
            dfg_size,
            taps,
            lights: norm,
        } => {
            g.technique = technique::SPLIT_SUM;
            (g.last_lod, g.data_offset, g.size, g.samples) = (last_lod, dfg_offset, dfg_size, taps);
            g.light_norm = norm.unwrap_or(0.0);
            g.flags = lights(norm.is_some());
        }
    }
    g
}

/// A shape and its albedo: a Lambertian object, shaded by SH irradiance unless its GPU record
/// says otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Object {
    /// The shape.
    pub shape: Shape,
    /// Diffuse albedo, RGB.
    pub albedo: [f64; 3],
}

impl Object {
    /// Its record: Lambert, SH irradiance from coefficients at offset 0 of order `lmax`.
    pub fn gpu(&self, lmax: u32) -> ObjectRecord {
        let shading = Shading::Sh {
            offset: 0,
            order: lmax,
            lights: false,
        };
        object_record(&self.shape, self.albedo, &Brdf::Lambert, shading)
    }
}

/// Bit `id` for each BRDF id among `ids` (`crate::abi::brdf::ids`).
pub fn brdf_bits(ids: impl IntoIterator<Item = u32>) -> u32 {
    ids.into_iter()
        .fold(0, |bits, id| bits | 1u32.checked_shl(id).unwrap_or(0))
}

/// The G-buffer of one frame: three RGBA32F images, and the objects it was made from.
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Normal (xyz) and object index (w; −1 where the ray missed).
    pub normal: GpuEnvMap,
    /// Hit position (xyz) and distance (w).
    pub position: GpuEnvMap,
    /// Unit direction towards the eye (xyz); for misses, minus the ray's direction.
    pub view: GpuEnvMap,
    /// The objects, as the shaders read them.
    pub objects: Buffer,
    /// How many.
    pub count: u32,
    /// The BRDFs they use, bit `id` for BRDF `id` ([`brdf_bits`]).
    pub brdfs: u32,
    /// The camera whose rays made it, where known: footprint lookups cast sub-pixel rays.
    pub camera: Option<Camera>,
}

/// The camera as `glsl/include/scene.glsl`'s `camera_ray` reads it: eye (w: 1 for
/// orthographic), unit forward, right and up scaled by the image plane's half extents, and
/// the image size.
pub fn camera_record(camera: &Camera) -> [[f32; 4]; 5] {
    let f = camera.frame();
    let (hx, hy) = camera.half_extent();
    let v4 = |v: glam::DVec3, w: f32| [v.x as f32, v.y as f32, v.z as f32, w];
    let ortho = matches!(camera.projection, Projection::Orthographic { .. });
    [
        v4(glam::DVec3::from(camera.eye), ortho as u32 as f32),
        v4(f.forward, 0.0),
        v4(f.right * hx, 0.0),
        v4(f.up * hy, 0.0),
        [camera.width as f32, camera.height as f32, 0.0, 0.0],
    ]
}

/// A colour target: a one-layer image stored as a [`GpuEnvMap`] (its mapping field is
/// `LatLong` only so that it can be downloaded like a map), rendered to, then sampled.
pub fn target(ctx: &Context, name: &str, w: u32, h: u32) -> Result<GpuEnvMap> {
    GpuEnvMap::create(
        ctx,
        name,
        ImageDesc {
            width: w,
            height: h,
            layers: 1,
            format: FORMAT,
            usage: TARGET_USAGE,
            cube: false,
            mips: 1,
        },
        Mapping::LatLong,
    )
}

impl GBuffer {
    /// Allocates the images of a `w` × `h` G-buffer and uploads `objects`.
    pub fn new(ctx: &Context, w: u32, h: u32, objects: &[ObjectRecord]) -> Result<GBuffer> {
        if w == 0 || h == 0 || objects.is_empty() {
            return Err(crate::Error::Invalid(
                "a G-buffer needs a non-empty image and at least one object".into(),
            ));
        }
        Ok(GBuffer {
            width: w,
            height: h,
            normal: target(ctx, "gbuffer normal", w, h)?,
            position: target(ctx, "gbuffer position", w, h)?,
            view: target(ctx, "gbuffer view", w, h)?,
            objects: Buffer::storage(ctx, "scene objects", objects)?,
            count: objects.len() as u32,
            brdfs: brdf_bits(objects.iter().map(|o| o.brdf)),
            camera: None,
        })
    }
}

/// The G-buffer pass.
pub struct GBufferPass {
    ctx: Context,
    pipeline: Pipeline,
}

impl GBufferPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<GBufferPass> {
        Ok(GBufferPass {
            ctx: ctx.clone(),
            pipeline: Pipeline::fullscreen(
                ctx,
                ShaderId::FullscreenVert,
                ShaderId::GBuffer,
                &[FORMAT; 3],
            )?,
        })
    }

    /// Records the casting of the camera's rays against `gbuf`'s objects into its images
    /// (the camera's size must be the G-buffer's). Span: "gbuffer".
    pub fn record(&self, rec: &mut Recorder, camera: &Camera, gbuf: &GBuffer) -> Result<()> {
        let (w, h) = (camera.width, camera.height);
        assert_eq!(
            (w, h),
            (gbuf.width, gbuf.height),
            "camera and G-buffer sizes differ"
        );
        let f = camera.frame();
        let (hx, hy) = camera.half_extent();
        let v4 = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        let push = GBufferPush {
            eye: v4(glam::DVec3::from(camera.eye)),
            forward: v4(f.forward),
            right: v4(f.right * hx),
            up: v4(f.up * hy),
            size: [w, h],
            ortho: matches!(camera.projection, Projection::Orthographic { .. }) as u32,
            count: gbuf.count,
        };
        rec.span("gbuffer", |rec| {
            rec.draw_fullscreen(
                &self.pipeline,
                &[(binding::GBUF_OBJECTS, Bind::Buffer(&gbuf.objects))],
                &push,
                &[&gbuf.normal.image, &gbuf.position.image, &gbuf.view.image],
            )
        })?;
        for image in [&gbuf.normal.image, &gbuf.position.image, &gbuf.view.image] {
            poison::image(rec, PassId::GBuffer, image, 0..1)?;
        }
        Ok(())
    }

    /// Casts the camera's rays against `objects` into a new G-buffer and waits.
    pub fn run(&self, camera: &Camera, objects: &[ObjectRecord]) -> Result<Timed<GBuffer>> {
        let g = GBuffer::new(&self.ctx, camera.width, camera.height, objects)?;
        Ok(self
            .ctx
            .run("drawing the G-buffer", |rec| self.record(rec, camera, &g))?
            .map(|()| g))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abi::brdf::ids;

    const BALL: Shape = Shape::Sphere {
        center: [1.0, 2.0, 3.0],
        radius: 0.5,
    };

    /// Each technique's data lands in its own named field, integers as integers, and the
    /// lights and rotation flags are set exactly where asked.
    #[test]
    fn records_carry_each_technique_in_its_own_fields() {
        let ggx = Brdf::Ggx {
            alpha: 0.3,
            correlated: true,
        };
        let fis = |lights| Shading::Fis {
            samples: 64,
            lod_bias: 1.5,
            rotate: true,
            lights,
        };
        let r = object_record(&BALL, [0.5, 0.25, 1.0], &ggx, fis(Some(0.4)));
        assert_eq!(
            (r.kind, r.shape, r.albedo),
            (object::SPHERE, [1.0, 2.0, 3.0, 0.5], [0.5, 0.25, 1.0, 0.0])
        );
        assert_eq!(
            (r.technique, r.brdf, r.params),
            (technique::FIS, ids::GGX, [0.3, 1.0])
        );
        assert_eq!((r.samples, r.lod_bias, r.lobe), (64, 1.5, 0.4));
        assert_eq!(r.flags, object::ROTATE | object::LIGHTS);
        assert_eq!(
            object_record(&BALL, [1.0; 3], &ggx, fis(None)).flags,
            object::ROTATE
        );

        let split = Shading::SplitSum {
            last_lod: 6.0,
            dfg_offset: 1024,
            dfg_size: 32,
            taps: 4,
            lights: Some(0.125),
        };
        let r = object_record(&BALL, [1.0; 3], &ggx, split);
        assert_eq!(
            (r.technique, r.last_lod, r.data_offset, r.size),
            (technique::SPLIT_SUM, 6.0, 1024, 32)
        );
        assert_eq!(
            (r.samples, r.light_norm, r.flags),
            (4, 0.125, object::LIGHTS)
        );

        let sh = Shading::Sh {
            offset: 81,
            order: 8,
            lights: false,
        };
        let r = object_record(&BALL, [1.0; 3], &Brdf::Lambert, sh);
        assert_eq!(
            (r.technique, r.data_offset, r.size, r.flags),
            (technique::SH, 81, 8, 0)
        );

        let phong = Brdf::Phong { n: 50.0 };
        let pre = Shading::Prefiltered {
            offset: 4096,
            width: 16,
            lights: Some(0.2),
        };
        let r = object_record(&BALL, [1.0; 3], &phong, pre);
        assert_eq!(
            (r.technique, r.data_offset, r.size),
            (technique::PREFILTERED, 4096, 16)
        );
        assert_eq!(
            (r.params, r.lobe, r.flags),
            ([50.0, 0.0], 0.2, object::LIGHTS)
        );

        let kautz = Shading::ShBrdf {
            grid: 16,
            offset: 9,
            order: 6,
            table: 70000,
        };
        let r = object_record(&BALL, [1.0; 3], &phong, kautz);
        assert_eq!(
            (r.technique, r.grid, r.data_offset, r.size, r.table_offset),
            (technique::SH_BRDF, 16, 9, 6, 70000)
        );
        // Past 2^24, an id or offset stored as f32 would have rounded; as u32 it is exact.
        let far = Shading::Sh {
            offset: (1 << 24) + 1,
            order: 2,
            lights: true,
        };
        let r = object_record(&BALL, [1.0; 3], &Brdf::Lambert, far);
        assert_eq!((r.data_offset, r.flags), ((1 << 24) + 1, object::LIGHTS));
    }

    /// A plane's record: its unit normal (normalised here), offset and extent.
    #[test]
    fn plane_records_hold_a_unit_normal() {
        let plane = Shape::Plane {
            normal: [0.0, 2.0, 0.0],
            offset: -0.75,
            extent: 6.0,
        };
        let r = object_record(&plane, [1.0; 3], &Brdf::Mirror, Shading::Lookup);
        assert_eq!(
            (r.kind, r.shape, r.extent),
            (object::PLANE, [0.0, 1.0, 0.0, -0.75], 6.0)
        );
        assert_eq!(
            (r.technique, r.brdf, r.flags),
            (technique::LOOKUP, ids::MIRROR, 0)
        );
    }
}
