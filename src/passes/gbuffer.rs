//! The G-buffer: analytic spheres and planes ray cast per pixel by a fullscreen fragment pass
//! (`glsl/gbuffer.frag`, float64 twin `crate::math::camera`). Shading passes read it: SH
//! diffuse shading here, glossy techniques later, all from the same three images.

use super::map::GpuEnvMap;
use crate::abi::{binding, brdf, push::GBufferPush, ShaderId};
use crate::error::Result;
use crate::gpu::{Bind, Buffer, Context, ImageDesc, Pipeline, Recorder, Timing};
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

/// An object of the scene as the GPU reads it (`Object` in `glsl/include/scene.glsl`): its
/// shape, and its material and technique for the shading passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuObject {
    /// Sphere: centre, radius. Plane: unit normal, offset.
    pub a: [f32; 4],
    /// x: 0 sphere, 1 plane; y: plane extent.
    pub b: [f32; 4],
    /// Albedo or specular colour (rgb); w: technique id.
    pub albedo: [f32; 4],
    /// x: BRDF id; y, z: its parameters; w: FIS sample count.
    pub brdf: [f32; 4],
    /// x: FIS lod bias; y: offset of the object's data; z: SH lmax or prefiltered width;
    /// w: flags (bit 0: rotate FIS samples per pixel).
    pub extra: [f32; 4],
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
    /// Its GPU record: Lambert, SH technique with coefficients at offset 0 of order `lmax`.
    pub fn gpu(&self, lmax: u32) -> GpuObject {
        let albedo = [
            self.albedo[0] as f32,
            self.albedo[1] as f32,
            self.albedo[2] as f32,
            brdf::technique::SH as f32,
        ];
        let mut g = shape_record(&self.shape);
        g.albedo = albedo;
        g.brdf = [brdf::ids::LAMBERT as f32, 0.0, 0.0, 0.0];
        g.extra = [0.0, 0.0, lmax as f32, 0.0];
        g
    }
}

/// The shape part of a GPU record (material fields zero).
pub fn shape_record(shape: &Shape) -> GpuObject {
    {
        let albedo = [0.0; 4];
        match *shape {
            Shape::Sphere { center, radius } => GpuObject {
                a: [
                    center[0] as f32,
                    center[1] as f32,
                    center[2] as f32,
                    radius as f32,
                ],
                b: [0.0; 4],
                albedo,
                ..Default::default()
            },
            Shape::Plane {
                normal,
                offset,
                extent,
            } => {
                let n = glam::DVec3::from(normal).normalize();
                GpuObject {
                    a: [n.x as f32, n.y as f32, n.z as f32, offset as f32],
                    b: [1.0, extent as f32, 0.0, 0.0],
                    albedo,
                    ..Default::default()
                }
            }
        }
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
    pub fn new(ctx: &Context, w: u32, h: u32, objects: &[GpuObject]) -> Result<GBuffer> {
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
            brdfs: brdf_bits(objects.iter().map(|o| o.brdf[0] as u32)),
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
    pub fn run(&self, camera: &Camera, objects: &[GpuObject]) -> Result<(GBuffer, Vec<Timing>)> {
        let g = GBuffer::new(&self.ctx, camera.width, camera.height, objects)?;
        let ((), t) = self
            .ctx
            .run("drawing the G-buffer", |rec| self.record(rec, camera, &g))?;
        Ok((g, t))
    }
}
