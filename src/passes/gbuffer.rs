//! The G-buffer: analytic spheres and planes ray cast per pixel by a fullscreen fragment pass
//! (`glsl/gbuffer.frag`, float64 twin [`crate::math::camera`]). Shading passes read it: SH
//! diffuse shading here, glossy techniques later, all from the same three images.

use crate::error::Result;
use crate::gpu::barrier::{cmd_image_barriers, image_barrier, Usage};
use crate::gpu::layout::binding;
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{Buffer, Context, GpuEnvMap, Image, Timing};
use crate::math::camera::{Camera, Projection, Shape};
use crate::math::Mapping;
use ash::vk;

/// Format of the G-buffer images and of shaded frames.
pub const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Push constants of `glsl/gbuffer.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GBufferPush {
    /// Eye position.
    pub eye: [f32; 4],
    /// Unit forward.
    pub forward: [f32; 4],
    /// Right, scaled by the image plane's half width.
    pub right: [f32; 4],
    /// Up, scaled by the half height.
    pub up: [f32; 4],
    /// Image size.
    pub size: [u32; 2],
    /// 1 for orthographic.
    pub ortho: u32,
    /// Number of objects.
    pub count: u32,
}

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
            crate::gpu::layout::brdf::technique::SH as f32,
        ];
        let mut g = shape_record(&self.shape);
        g.albedo = albedo;
        g.brdf = [crate::gpu::layout::brdf::ids::LAMBERT as f32, 0.0, 0.0, 0.0];
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
}

/// A colour target: a one-layer image stored as a [`GpuEnvMap`] (its mapping field is
/// `LatLong` only so that it can be downloaded like a map), rendered to, then sampled.
pub(crate) fn target(ctx: &Context, name: &str, w: u32, h: u32) -> Result<GpuEnvMap> {
    GpuEnvMap::with_usage(
        ctx,
        name,
        Mapping::LatLong,
        w,
        h,
        vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC,
    )
}

/// Records a timed fullscreen draw of `pipeline` into `targets`, one-layer images of equal
/// size with SAMPLED usage (from undefined to sampled by fragment shaders).
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_fullscreen<P: bytemuck::Pod>(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    spans: &mut Spans,
    label: &str,
    pipeline: &Pipeline,
    set: Option<&DescriptorSet>,
    push: &P,
    targets: &[&Image],
) {
    let d = ctx.device();
    let (w, h) = (targets[0].desc().width, targets[0].desc().height);
    let before: Vec<_> = targets
        .iter()
        .map(|t| image_barrier(t.raw(), 1, Usage::Undefined, Usage::ColorAttachment))
        .collect();
    cmd_image_barriers(d, cmd, &before);
    let span = spans.begin(cmd, label);
    let attachments: Vec<_> = targets
        .iter()
        .map(|t| {
            vk::RenderingAttachmentInfo::default()
                .image_view(t.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::DONT_CARE)
                .store_op(vk::AttachmentStoreOp::STORE)
        })
        .collect();
    let area = vk::Rect2D {
        offset: vk::Offset2D::default(),
        extent: vk::Extent2D {
            width: w,
            height: h,
        },
    };
    let rendering = vk::RenderingInfo::default()
        .render_area(area)
        .layer_count(1)
        .color_attachments(&attachments);
    // SAFETY: cmd is recording; the attachments are live and in the right layout.
    unsafe {
        d.cmd_begin_rendering(cmd, &rendering);
        pipeline.bind(cmd, set, push);
        d.cmd_set_viewport(
            cmd,
            0,
            &[vk::Viewport {
                x: 0.0,
                y: 0.0,
                width: w as f32,
                height: h as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            }],
        );
        d.cmd_set_scissor(cmd, 0, &[area]);
        d.cmd_draw(cmd, 3, 1, 0, 0);
        d.cmd_end_rendering(cmd);
    }
    spans.end(cmd, span);
    let after: Vec<_> = targets
        .iter()
        .map(|t| image_barrier(t.raw(), 1, Usage::ColorAttachment, Usage::FragmentSampled))
        .collect();
    cmd_image_barriers(d, cmd, &after);
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

    /// Casts the camera's rays against `objects`. The images end up ready for sampling by
    /// fragment shaders.
    pub fn run(&self, camera: &Camera, objects: &[GpuObject]) -> Result<(GBuffer, Vec<Timing>)> {
        let (w, h) = (camera.width, camera.height);
        if w == 0 || h == 0 || objects.is_empty() {
            return Err(crate::Error::Invalid(
                "a G-buffer needs a non-empty image and at least one object".into(),
            ));
        }
        let buf = Buffer::storage(&self.ctx, "scene objects", objects)?;
        let g = GBuffer {
            width: w,
            height: h,
            normal: target(&self.ctx, "gbuffer normal", w, h)?,
            position: target(&self.ctx, "gbuffer position", w, h)?,
            view: target(&self.ctx, "gbuffer view", w, h)?,
            objects: buf,
            count: objects.len() as u32,
        };
        let set = DescriptorSet::new(
            &self.ctx,
            &self.pipeline,
            &[(binding::GBUF_OBJECTS, Bind::Buffer(&g.objects))],
        )?;
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
            count: objects.len() as u32,
        };
        let mut spans = Spans::new(&self.ctx, 1)?;
        self.ctx.submit_and_wait("drawing the G-buffer", |cmd| {
            spans.reset(cmd);
            record_fullscreen(
                &self.ctx,
                cmd,
                &mut spans,
                "gbuffer",
                &self.pipeline,
                Some(&set),
                &push,
                &[&g.normal.image, &g.position.image, &g.view.image],
            );
            Ok(())
        })?;
        let timings = spans.read()?;
        Ok((g, timings))
    }
}
