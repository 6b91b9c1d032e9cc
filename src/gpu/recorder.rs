//! Recording into a command buffer someone else owns. Passes never submit: they record their
//! dispatches, draws and copies through a [`Recorder`], which places every barrier from the
//! usages each command declares (a binding's kind and access in the shader table, or a copy's
//! source and destination) and the usage each resource was last left in. [`Context::run`] is
//! the one place that submits and waits, for the CLI, tests and one-off jobs.

use super::barrier::{
    buffer_needs_barrier, image_barrier, memory_barrier, needs_barrier, usage_info, Usage,
};
use super::context::Context;
use super::pipeline::{Bind, DescriptorSet, FrameCache, Pipeline};
use super::resources::{Buffer, Image};
use super::shaders::binding_usage;
use super::timing::{Timed, Timestamps, Timing};
use crate::abi::PushBlock;
use crate::error::Result;
use ash::vk;
use std::any::Any;

/// Records envlight's commands into a command buffer in the recording state, outside a render
/// pass. Made by [`Recorder::begin`] on the caller's command buffer, or by [`Context::run`].
///
/// Every resource remembers how the last command recorded so far used it; a command that
/// uses it otherwise gets the barrier between the two first. Resources that only this
/// recording needs (descriptor sets, staging buffers) are kept by the recorder and handed to
/// the [`Recorded`] that [`Recorder::finish`] returns, which must outlive the GPU's work.
pub struct Recorder {
    ctx: Context,
    cmd: vk::CommandBuffer,
    timestamps: Option<Timestamps>,
    keep: Vec<Box<dyn Any>>,
    /// Where descriptor sets and transient buffers are kept across recordings, if anywhere.
    cache: Option<FrameCache>,
    /// Scratch buffers asked for so far in this recording, by name, size and usage.
    scratch_asked: std::collections::HashMap<(String, u64, u32), usize>,
    /// Scratch images asked for so far in this recording, by name and description.
    images_asked: std::collections::HashMap<(String, [u32; 7]), usize>,
}

/// What a finished recording holds until the GPU has executed it: the transient resources and
/// the timestamp queries.
pub struct Recorded {
    timestamps: Option<Timestamps>,
    /// Kept alive until dropped; never read.
    _keep: Vec<Box<dyn Any>>,
}

impl Recorded {
    /// The GPU time of every span recorded, in order of beginning. Call only after the
    /// command buffer has completed (empty where timestamps were off or unsupported).
    pub fn timings(&self) -> Result<Vec<Timing>> {
        match &self.timestamps {
            Some(t) => t.read(),
            None => Ok(Vec::new()),
        }
    }
}

impl Recorder {
    /// Starts recording into `cmd`. With `timestamps`, spans are timed where the queue
    /// supports timestamps.
    ///
    /// # Safety
    /// `cmd` must be a primary command buffer of `ctx`'s device, in the recording state and
    /// outside a render pass, to be submitted to a queue of [`Context::queue_family`]. The
    /// caller must keep the [`Recorded`] that [`Recorder::finish`] returns, and every resource
    /// passed to the passes, alive until that submission has completed, and submit work in the
    /// order it was recorded (each resource's tracked usage follows recording order).
    pub unsafe fn begin(ctx: &Context, cmd: vk::CommandBuffer, timestamps: bool) -> Recorder {
        let timestamps = (timestamps && ctx.info().timestamp_valid_bits > 0)
            .then(|| Timestamps::new(&ctx.shared));
        Recorder {
            ctx: ctx.clone(),
            cmd,
            timestamps,
            keep: Vec::new(),
            cache: None,
            scratch_asked: Default::default(),
            images_asked: Default::default(),
        }
    }

    /// Takes descriptor sets and transient buffers from `cache` from now on, making only
    /// those it lacks: a frame recorded again with the same passes on the same resources then
    /// allocates nothing (with timestamps off, whose query pools are per recording).
    pub fn use_frame_cache(&mut self, cache: &FrameCache) {
        self.cache = Some(cache.clone());
    }

    /// Replaces the frame cache in use (`None`: everything per recording), returning the one
    /// before, for a caller to restore.
    pub fn swap_frame_cache(&mut self, cache: Option<FrameCache>) -> Option<FrameCache> {
        std::mem::replace(&mut self.cache, cache)
    }

    /// A storage buffer holding `data` for this recording's commands (kept until it has
    /// executed); from the frame cache where one is in use and it holds one of that name and
    /// contents.
    pub(crate) fn upload<T: bytemuck::Pod>(
        &mut self,
        name: &str,
        data: &[T],
    ) -> Result<std::sync::Arc<Buffer>> {
        let b = match &self.cache {
            Some(c) => c.upload(&self.ctx, name, bytemuck::cast_slice(data))?,
            None => std::sync::Arc::new(Buffer::storage(&self.ctx, name, data)?),
        };
        self.keep(b.clone());
        Ok(b)
    }

    /// An image of `desc` for this recording's commands (kept until it has executed): the
    /// same image every recording asks for in the same order where a frame cache is in use.
    pub(crate) fn scratch_image(
        &mut self,
        name: &str,
        desc: super::ImageDesc,
    ) -> Result<std::sync::Arc<Image>> {
        let i = match &self.cache {
            Some(c) => {
                let key = super::pipeline::image_key(&desc);
                let asked = self
                    .images_asked
                    .entry((name.to_string(), key))
                    .or_insert(0);
                *asked += 1;
                c.image(&self.ctx, name, desc, *asked - 1)?
            }
            None => std::sync::Arc::new(Image::new(&self.ctx, name, desc)?),
        };
        self.keep(i.clone());
        Ok(i)
    }

    /// A GPU-only buffer of `size` bytes and `usage` for this recording's commands (kept
    /// until it has executed): the same buffer every recording asks for in the same order
    /// where a frame cache is in use.
    pub(crate) fn scratch(
        &mut self,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<std::sync::Arc<Buffer>> {
        let b = match &self.cache {
            Some(c) => {
                let asked = self
                    .scratch_asked
                    .entry((name.to_string(), size, usage.as_raw()))
                    .or_insert(0);
                *asked += 1;
                c.scratch(&self.ctx, (name, size, usage), *asked - 1)?
            }
            None => std::sync::Arc::new(Buffer::new(
                &self.ctx,
                name,
                size,
                usage,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?),
        };
        self.keep(b.clone());
        Ok(b)
    }

    /// Ends recording (the command buffer stays in the recording state, the caller's).
    pub fn finish(self) -> Recorded {
        Recorded {
            timestamps: self.timestamps,
            _keep: self.keep,
        }
    }

    /// The context.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The command buffer being recorded.
    pub fn command_buffer(&self) -> vk::CommandBuffer {
        self.cmd
    }

    /// Keeps `resource` alive until the recording has executed.
    pub fn keep<T: 'static>(&mut self, resource: T) {
        self.keep.push(Box::new(resource));
    }

    /// Spans begun so far (0 where timestamps are off), to attribute timings to callers.
    pub fn spans(&self) -> usize {
        self.timestamps.as_ref().map_or(0, |t| t.len())
    }

    /// Records `f` inside a timed span labelled `label`.
    pub fn span<R>(
        &mut self,
        label: &str,
        f: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<R> {
        if let Some(t) = self.timestamps.as_mut() {
            t.begin(self.cmd, label)?;
        }
        let r = f(self);
        if let Some(t) = self.timestamps.as_mut() {
            t.end(self.cmd);
        }
        r
    }

    /// Declares that the next command uses `image` as `usage`, recording the barrier from
    /// its last usage where one is needed. `Usage::Undefined` as the new usage is refused:
    /// to discard contents, use [`Recorder::discard`].
    pub fn use_image(&mut self, image: &Image, usage: Usage) {
        assert_ne!(
            usage,
            Usage::Undefined,
            "an image cannot be used as Undefined"
        );
        let mut state = image.state.lock().unwrap_or_else(|e| e.into_inner());
        if needs_barrier(*state, usage) {
            let b = image_barrier(image.raw, image.desc().layers, *state, usage);
            let bs = [b];
            let dep = vk::DependencyInfo::default().image_memory_barriers(&bs);
            // SAFETY: cmd is recording outside a render pass; the image is live.
            unsafe { self.ctx.device().cmd_pipeline_barrier2(self.cmd, &dep) };
        }
        *state = usage;
    }

    /// Declares that `image`'s contents are not needed: the next use transitions it from
    /// undefined (no wait, no copy of old contents).
    pub fn discard(&mut self, image: &Image) {
        *image.state.lock().unwrap_or_else(|e| e.into_inner()) = Usage::Undefined;
    }

    /// Declares that the next command uses `buffer` as `usage` (as [`Recorder::use_image`]).
    pub fn use_buffer(&mut self, buffer: &Buffer, usage: Usage) {
        let mut state = buffer.state.lock().unwrap_or_else(|e| e.into_inner());
        if buffer_needs_barrier(*state, usage) {
            let bs = [memory_barrier(*state, usage)];
            let dep = vk::DependencyInfo::default().memory_barriers(&bs);
            // SAFETY: cmd is recording outside a render pass.
            unsafe { self.ctx.device().cmd_pipeline_barrier2(self.cmd, &dep) };
        }
        *state = usage;
    }

    /// Declares the usage every binding implies (from the shader table's kind and access),
    /// writes a descriptor set for them, and binds pipeline, set and push constants.
    fn bind<P: PushBlock>(
        &mut self,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
        push: &P,
    ) -> Result<()> {
        let iface = pipeline.shader().interface();
        let compute = pipeline.is_compute();
        for (b, bind) in binds {
            let &(_, kind, access) = iface
                .bindings
                .iter()
                .find(|(n, _, _)| n == b)
                .unwrap_or_else(|| panic!("{:?} has no binding {b}", pipeline.shader()));
            let usage = binding_usage(compute, kind, access);
            if let Some(i) = bind.image() {
                self.use_image(i, usage);
            }
            if let Some(buf) = bind.buffer() {
                self.use_buffer(buf, usage);
            }
        }
        let set = match (&self.cache, binds.is_empty()) {
            (_, true) => None,
            (Some(cache), false) => Some(cache.set(&self.ctx, pipeline, binds)?),
            (None, false) => Some(std::sync::Arc::new(DescriptorSet::new(
                &self.ctx, pipeline, binds,
            )?)),
        };
        pipeline.bind(self.cmd, set.as_deref(), push);
        if let Some(s) = set {
            self.keep(s);
        }
        Ok(())
    }

    /// Records a dispatch of the compute `pipeline` with `binds` and `push`, over `groups`
    /// workgroups, after the barriers its bindings need.
    pub(crate) fn dispatch<P: PushBlock>(
        &mut self,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
        push: &P,
        groups: [u32; 3],
    ) -> Result<()> {
        assert!(
            pipeline.is_compute(),
            "{:?} is not compute",
            pipeline.shader()
        );
        self.bind(pipeline, binds, push)?;
        // SAFETY: cmd is recording with the compute pipeline and its set bound.
        unsafe {
            self.ctx
                .device()
                .cmd_dispatch(self.cmd, groups[0], groups[1], groups[2])
        };
        Ok(())
    }

    /// Records a dispatch of the compute `pipeline` as [`Recorder::dispatch`] does, its
    /// workgroup counts read by the GPU from the three u32 at byte `offset` of `args` (a
    /// buffer made with INDIRECT_BUFFER usage, written by an earlier pass).
    pub(crate) fn dispatch_indirect<P: PushBlock>(
        &mut self,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
        push: &P,
        args: (&Buffer, u64),
    ) -> Result<()> {
        assert!(
            pipeline.is_compute(),
            "{:?} is not compute",
            pipeline.shader()
        );
        assert!(args.1.is_multiple_of(4) && args.1 + 12 <= args.0.size());
        // The arguments' read waits for their writer; a binding of the same buffer then
        // waits for the read (write after read).
        self.use_buffer(args.0, Usage::IndirectRead);
        self.bind(pipeline, binds, push)?;
        // SAFETY: cmd is recording with the compute pipeline and its set bound; the
        // arguments lie inside the live buffer and were made visible to the indirect stage.
        unsafe {
            self.ctx
                .device()
                .cmd_dispatch_indirect(self.cmd, args.0.raw, args.1)
        };
        Ok(())
    }

    /// Fills the first `bytes` of `buffer` (made with TRANSFER_DST usage) with the u32
    /// `value`.
    pub fn fill_buffer(&mut self, buffer: &Buffer, bytes: u64, value: u32) {
        assert!(bytes.is_multiple_of(4) && bytes <= buffer.size());
        self.use_buffer(buffer, Usage::TransferDst);
        // SAFETY: cmd is recording outside a render pass; the range lies inside the live
        // buffer, a multiple of 4 bytes from offset 0.
        unsafe {
            self.ctx
                .device()
                .cmd_fill_buffer(self.cmd, buffer.raw, 0, bytes, value)
        };
    }

    /// Records a fullscreen draw of the graphics `pipeline` into `targets` (one-layer images
    /// of equal size, contents discarded), after the barriers its bindings need.
    pub(crate) fn draw_fullscreen<P: PushBlock>(
        &mut self,
        pipeline: &Pipeline,
        binds: &[(u32, Bind<'_>)],
        push: &P,
        targets: &[&Image],
    ) -> Result<()> {
        assert!(!pipeline.is_compute() && !targets.is_empty());
        let (w, h) = (targets[0].desc().width, targets[0].desc().height);
        for t in targets {
            assert_eq!((t.desc().width, t.desc().height), (w, h));
            self.discard(t);
            self.use_image(t, Usage::ColorAttachment);
        }
        let attachments: Vec<_> = targets
            .iter()
            .map(|t| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(t.view)
                    .image_layout(usage_info(Usage::ColorAttachment).layout)
                    .load_op(vk::AttachmentLoadOp::DONT_CARE)
                    .store_op(vk::AttachmentStoreOp::STORE)
            })
            .collect();
        // Bindings' barriers go before the render pass begins.
        self.bind(pipeline, binds, push)?;
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
        let d = self.ctx.device();
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: w as f32,
            height: h as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: cmd is recording; the attachments are live and in the attachment layout;
        // the pipeline was bound above and binding state survives vkCmdBeginRendering.
        unsafe {
            d.cmd_begin_rendering(self.cmd, &rendering);
            d.cmd_set_viewport(self.cmd, 0, &[viewport]);
            d.cmd_set_scissor(self.cmd, 0, &[area]);
            d.cmd_draw(self.cmd, 3, 1, 0, 0);
            d.cmd_end_rendering(self.cmd);
        }
        Ok(())
    }

    /// Copies `src` (tightly packed texels, layer after layer) into MIP level `level` of
    /// `dst`, whose earlier contents are discarded when `discard`.
    pub fn copy_buffer_to_image(&mut self, src: &Buffer, dst: &Image, level: u32, discard: bool) {
        self.copy_region(src, dst, discard, level_region(dst, level));
    }

    /// Copies `src` into `region` of `dst` (discarding its earlier contents when `discard`).
    fn copy_region(
        &mut self,
        src: &Buffer,
        dst: &Image,
        discard: bool,
        region: vk::BufferImageCopy,
    ) {
        self.use_buffer(src, Usage::TransferSrc);
        if discard {
            self.discard(dst);
        }
        self.use_image(dst, Usage::TransferDst);
        // SAFETY: cmd is recording; buffer and image are live, the image is in
        // TRANSFER_DST_OPTIMAL, and the callers keep the region inside the image and size
        // the buffer for it.
        unsafe {
            self.ctx.device().cmd_copy_buffer_to_image(
                self.cmd,
                src.raw,
                dst.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Copies `src` (tightly packed texels from its start) into rows `rows` of layer `layer`
    /// of level 0 of `dst`, whose earlier contents are discarded when `discard` (the first
    /// band of an upload in bands).
    pub fn copy_buffer_to_image_rows(
        &mut self,
        src: &Buffer,
        dst: &Image,
        layer: u32,
        rows: std::ops::Range<u32>,
        discard: bool,
    ) {
        let d = dst.desc();
        assert!(layer < d.layers && rows.start < rows.end && rows.end <= d.height);
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .base_array_layer(layer)
                    .layer_count(1),
            )
            .image_offset(vk::Offset3D {
                x: 0,
                y: rows.start as i32,
                z: 0,
            })
            .image_extent(vk::Extent3D {
                width: d.width,
                height: rows.end - rows.start,
                depth: 1,
            });
        self.copy_region(src, dst, discard, region);
    }

    /// Copies MIP level `level` of `src` into `dst` (tightly packed, layer after layer).
    pub fn copy_image_to_buffer(&mut self, src: &Image, level: u32, dst: &Buffer, offset: u64) {
        self.use_image(src, Usage::TransferSrc);
        self.use_buffer(dst, Usage::TransferDst);
        let region = level_region(src, level).buffer_offset(offset);
        // SAFETY: cmd is recording; both are live, the image is in TRANSFER_SRC_OPTIMAL and
        // the caller sized the buffer for the level.
        unsafe {
            self.ctx.device().cmd_copy_image_to_buffer(
                self.cmd,
                src.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw,
                &[region],
            )
        };
    }

    /// Copies MIP level `src_level` of `src` into level `dst_level` of `dst`, every layer: the
    /// two must share a format and the levels' extents and layer counts. The other levels of
    /// `dst` keep their contents.
    pub fn copy_image_level(&mut self, src: &Image, src_level: u32, dst: &Image, dst_level: u32) {
        let (a, b) = (src.desc(), dst.desc());
        let extent = |d: &super::ImageDesc, l: u32| ((d.width >> l).max(1), (d.height >> l).max(1));
        assert!(
            a.format == b.format
                && a.layers == b.layers
                && extent(a, src_level) == extent(b, dst_level)
                && src_level < a.mips
                && dst_level < b.mips,
            "copy_image_level: the levels differ in format, extent or layers"
        );
        self.use_image(src, Usage::TransferSrc);
        self.use_image(dst, Usage::TransferDst);
        let layers = |l: u32| {
            vk::ImageSubresourceLayers::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .mip_level(l)
                .layer_count(a.layers)
        };
        let (w, h) = extent(a, src_level);
        let region = vk::ImageCopy::default()
            .src_subresource(layers(src_level))
            .dst_subresource(layers(dst_level))
            .extent(vk::Extent3D {
                width: w,
                height: h,
                depth: 1,
            });
        // SAFETY: cmd is recording outside a render pass; both images are live, in
        // TRANSFER_SRC_OPTIMAL and TRANSFER_DST_OPTIMAL, and the region lies within both.
        unsafe {
            self.ctx.device().cmd_copy_image(
                self.cmd,
                src.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Copies the first `bytes` of `src` to the start of `dst`.
    pub fn copy_buffer(&mut self, src: &Buffer, dst: &Buffer, bytes: u64) {
        assert!(bytes <= src.size() && bytes <= dst.size());
        self.use_buffer(src, Usage::TransferSrc);
        self.use_buffer(dst, Usage::TransferDst);
        let region = vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: bytes,
        };
        // SAFETY: cmd is recording; both buffers are live and large enough.
        unsafe {
            self.ctx
                .device()
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &[region])
        };
    }

    /// Copies `regions` (source offset, destination offset, bytes) of `src` into `dst`.
    pub fn copy_buffer_regions(&mut self, src: &Buffer, dst: &Buffer, regions: &[(u64, u64, u64)]) {
        assert!(regions
            .iter()
            .all(|&(s, d, n)| s + n <= src.size() && d + n <= dst.size()));
        self.use_buffer(src, Usage::TransferSrc);
        self.use_buffer(dst, Usage::TransferDst);
        let regions: Vec<vk::BufferCopy> = regions
            .iter()
            .map(|&(src_offset, dst_offset, size)| vk::BufferCopy {
                src_offset,
                dst_offset,
                size,
            })
            .collect();
        // SAFETY: cmd is recording; every region lies inside both live buffers.
        unsafe {
            self.ctx
                .device()
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &regions)
        };
    }

    /// Clears every level and layer of `image` to `value`, discarding its contents.
    pub fn clear(&mut self, image: &Image, value: [f32; 4]) {
        self.discard(image);
        self.use_image(image, Usage::TransferDst);
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(vk::REMAINING_MIP_LEVELS)
            .layer_count(vk::REMAINING_ARRAY_LAYERS);
        // SAFETY: cmd is recording; the image is live and in TRANSFER_DST_OPTIMAL.
        unsafe {
            self.ctx.device().cmd_clear_color_image(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearColorValue { float32: value },
                &[range],
            )
        };
    }
}

fn level_region(image: &Image, level: u32) -> vk::BufferImageCopy {
    let d = image.desc();
    vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .mip_level(level)
                .layer_count(d.layers),
        )
        .image_extent(vk::Extent3D {
            width: (d.width >> level).max(1),
            height: (d.height >> level).max(1),
            depth: 1,
        })
}

/// Work [`Context::submit`] handed to the GPU and nobody has waited for yet. Dropping it
/// waits too, so what the recording keeps (and the value it returned, such as readbacks)
/// outlives the GPU's work.
pub struct InFlight<R> {
    ctx: Context,
    pending: Option<(vk::CommandBuffer, vk::Fence)>,
    recorded: Option<Recorded>,
    out: Option<R>,
}

impl<R> InFlight<R> {
    /// Waits for the work; returns what the recording returned and the GPU time of every
    /// span.
    pub fn wait(mut self) -> Result<Timed<R>> {
        if let Some((cmd, fence)) = self.pending.take() {
            self.ctx.shared.retire(cmd, fence)?;
        }
        let timings = match &self.recorded {
            Some(r) => r.timings()?,
            None => Vec::new(),
        };
        let out = self
            .out
            .take()
            .unwrap_or_else(|| unreachable!("set when submitted"));
        Ok(Timed::new(out, timings))
    }
}

impl<R> Drop for InFlight<R> {
    fn drop(&mut self) {
        if let Some((cmd, fence)) = self.pending.take() {
            let _ = self.ctx.shared.retire(cmd, fence);
        }
    }
}

impl Context {
    /// Records with `record` into a command buffer of envlight's own and submits it without
    /// waiting: the host may prepare the next submission (uploads included) while the GPU
    /// works. Submissions execute in the order they were made, which is the order resources'
    /// tracked usages assume.
    pub fn submit<R>(
        &self,
        what: &'static str,
        record: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<InFlight<R>> {
        let mut out = None;
        let mut recorded = None;
        let pending = self.shared.submit(what, |cmd| {
            // SAFETY: submit hands a fresh primary command buffer in the recording state and
            // submits it to this context's queue; InFlight keeps the Recorded (and the
            // recording's value) until the fence has signalled.
            let mut rec = unsafe { Recorder::begin(self, cmd, true) };
            let r = record(&mut rec);
            recorded = Some(rec.finish());
            out = Some(r?);
            Ok(())
        })?;
        Ok(InFlight {
            ctx: self.clone(),
            pending: Some(pending),
            recorded,
            out,
        })
    }

    /// Records with `record` into a command buffer of envlight's own, submits it, waits for
    /// it, and returns what `record` returned and the GPU time of every span. With
    /// [`Context::submit`], the one place envlight submits work; an engine records into its
    /// own command buffers instead ([`Recorder::begin`]).
    pub fn run<R>(
        &self,
        what: &'static str,
        record: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<Timed<R>> {
        self.run_with(what, true, record)
    }

    /// [`Context::run`] without timestamps, whose query pools each recording makes: how a
    /// frame is recorded when what it creates is counted ([`Context::objects_created`]).
    pub fn run_untimed<R>(
        &self,
        what: &'static str,
        record: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<R> {
        self.run_with(what, false, record)
            .map(|Timed { value: r, .. }| r)
    }

    fn run_with<R>(
        &self,
        what: &'static str,
        timestamps: bool,
        record: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<Timed<R>> {
        let mut out = None;
        let mut recorded = None;
        self.shared.submit_and_wait(what, |cmd| {
            // SAFETY: submit_and_wait hands a fresh primary command buffer in the recording
            // state, submits it to this context's queue, and waits before returning; the
            // Recorded is kept past that wait.
            let mut rec = unsafe { Recorder::begin(self, cmd, timestamps) };
            let r = record(&mut rec);
            recorded = Some(rec.finish());
            out = Some(r?);
            Ok(())
        })?;
        let timings = match &recorded {
            Some(r) => r.timings()?,
            None => Vec::new(),
        };
        let out = out.unwrap_or_else(|| unreachable!("set when recording succeeded"));
        Ok(Timed::new(out, timings))
    }
}
