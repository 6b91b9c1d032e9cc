//! RAII buffers, images and samplers holding their gpu-allocator allocation. Each keeps the
//! context alive, so teardown order is right by construction.

use super::barrier::Usage;
use super::context::{Context, Shared};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::{Arc, Mutex};

/// Allocates memory for `requirements` (named for leak reports).
fn allocate(
    shared: &Shared,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    shared
        .allocator()
        .allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|source| Error::Alloc {
            what: name.to_string(),
            source,
        })
}

/// A buffer and its memory.
pub struct Buffer {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Buffer,
    /// Unique in the process (descriptor caches key by it).
    pub(crate) serial: u64,
    /// Its rgba32f view where it was made with UNIFORM_TEXEL_BUFFER usage (else null).
    pub(crate) texel_view: vk::BufferView,
    allocation: Option<Allocation>,
    size: u64,
    /// How the last recorded command used it (see [`super::Recorder`]).
    pub(crate) state: Mutex<Usage>,
}

impl Buffer {
    /// Creates a buffer of `size` bytes in `location` (CpuToGpu and GpuToCpu are mapped).
    /// With UNIFORM_TEXEL_BUFFER usage it also gets a view of the whole buffer as rgba32f
    /// texels (`size` a multiple of 16), which `super::Bind::Texels` binds.
    pub fn new(
        ctx: &Context,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        let s = &ctx.shared;
        if size == 0 {
            return Err(Error::Invalid(format!("{name}: a buffer of 0 bytes")));
        }
        let max = s.info.max_storage_buffer_range;
        if usage.contains(vk::BufferUsageFlags::STORAGE_BUFFER) && size > max {
            return Err(Error::Invalid(format!(
                "{name}: a storage buffer of {size} bytes exceeds the device's \
                 maxStorageBufferRange ({max} bytes); use a smaller map or output"
            )));
        }
        let texels = usage.contains(vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER);
        let max_texels = s.info.max_texel_buffer_elements;
        if texels && (!size.is_multiple_of(16) || size / 16 > max_texels) {
            return Err(Error::Invalid(format!(
                "{name}: a texel buffer of {size} bytes is not whole rgba32f texels within the \
                 device's maxTexelBufferElements ({max_texels})"
            )));
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { s.device.create_buffer(&info, None) }.vk("creating a buffer")?;
        s.track();
        let mut buffer = Buffer {
            shared: s.clone(),
            raw,
            serial: super::context::next_serial(),
            texel_view: vk::BufferView::null(),
            allocation: None,
            size,
            state: Mutex::new(Usage::Undefined),
        };
        s.name(raw, name);
        // SAFETY: raw is a live buffer of this device.
        let requirements = unsafe { s.device.get_buffer_memory_requirements(raw) };
        let allocation = allocate(s, name, requirements, location, true)?;
        // SAFETY: the allocation satisfies the buffer's requirements and outlives it (Drop).
        unsafe {
            s.device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        }
        .vk("binding buffer memory")?;
        buffer.allocation = Some(allocation);
        if texels {
            let info = vk::BufferViewCreateInfo::default()
                .buffer(raw)
                .format(vk::Format::R32G32B32A32_SFLOAT)
                .offset(0)
                .range(vk::WHOLE_SIZE);
            // SAFETY: raw is bound to memory and was made with UNIFORM_TEXEL_BUFFER usage;
            // rgba32f texel buffers are a required format feature.
            buffer.texel_view = unsafe { s.device.create_buffer_view(&info, None) }
                .vk("creating a texel buffer view")?;
            s.track();
            s.name(buffer.texel_view, name);
        }
        Ok(buffer)
    }

    /// A host-written storage buffer holding `data` (at least 16 bytes, so that an empty
    /// list still binds).
    pub fn storage<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> Result<Buffer> {
        let bytes = std::mem::size_of_val(data).max(16) as u64;
        let mut b = Buffer::new(
            ctx,
            name,
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        b.write(data);
        Ok(b)
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The raw handle.
    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    /// Copies `data` to the start of a host-visible buffer.
    pub fn write<T: bytemuck::Pod>(&mut self, data: &[T]) {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .unwrap_or_else(|| panic!("write() needs a host-visible buffer"));
        slice[..bytes.len()].copy_from_slice(bytes);
    }

    /// Fills the first `count` values of `T` of a host-visible buffer in place, through `fill`
    /// (no staging copy in host memory: an 8 MB map's upload is written once, not twice).
    pub fn write_with<T: bytemuck::Pod, R>(
        &mut self,
        count: usize,
        fill: impl FnOnce(&mut [T]) -> R,
    ) -> R {
        let n = count * std::mem::size_of::<T>();
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .unwrap_or_else(|| panic!("write_with() needs a host-visible buffer"));
        fill(bytemuck::cast_slice_mut(&mut slice[..n]))
    }

    /// Reads `count` values of `T` from the start of a host-visible buffer.
    pub fn read<T: bytemuck::Pod>(&self, count: usize) -> Vec<T> {
        let slice = self
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .unwrap_or_else(|| panic!("read() needs a host-visible buffer"));
        let n = count * std::mem::size_of::<T>();
        bytemuck::pod_collect_to_vec(&slice[..n])
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if self.texel_view != vk::BufferView::null() {
            // SAFETY: every submission using the view was waited for; it goes before its buffer.
            unsafe {
                self.shared
                    .device
                    .destroy_buffer_view(self.texel_view, None)
            };
            self.shared.untrack();
        }
        // SAFETY: every submission using this buffer was waited for before returning.
        unsafe { self.shared.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            let _ = self.shared.allocator().free(a);
        }
        self.shared.untrack();
    }
}

/// What kind of image to create.
#[derive(Clone, Copy, Debug)]
pub struct ImageDesc {
    /// Width of one layer.
    pub width: u32,
    /// Height of one layer.
    pub height: u32,
    /// Array layers (6 for a cube).
    pub layers: u32,
    /// Texel format.
    pub format: vk::Format,
    /// Usage flags.
    pub usage: vk::ImageUsageFlags,
    /// Also create a cube view (needs 6 layers and square layers).
    pub cube: bool,
    /// MIP levels (1: none). With more, each level also gets an array view of its own, for
    /// storage access.
    pub mips: u32,
}

impl ImageDesc {
    /// The create info of an image of this description: what envlight makes, and what an
    /// engine's image handed to [`Image::from_raw`] must be created as.
    pub fn create_info(&self) -> vk::ImageCreateInfo<'static> {
        vk::ImageCreateInfo::default()
            .flags(if self.cube {
                vk::ImageCreateFlags::CUBE_COMPATIBLE
            } else {
                vk::ImageCreateFlags::empty()
            })
            .image_type(vk::ImageType::TYPE_2D)
            .format(self.format)
            .extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: 1,
            })
            .mip_levels(self.mips)
            .array_layers(self.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(self.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
    }
}

/// A 2D array image with its memory, an array view and, for cubes, a cube view.
pub struct Image {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Image,
    /// Unique in the process (descriptor caches key by it).
    pub(crate) serial: u64,
    allocation: Option<Allocation>,
    pub(crate) view: vk::ImageView,
    pub(crate) cube_view: vk::ImageView,
    pub(crate) level_views: Vec<vk::ImageView>,
    desc: ImageDesc,
    /// How the last recorded command used it (see [`super::Recorder`]).
    pub(crate) state: Mutex<Usage>,
    /// Whether envlight created the image (and so destroys it); views are always envlight's.
    owned: bool,
    /// The name it was made or wrapped with (for errors).
    name: String,
}

impl Image {
    /// Creates the image, its memory and its views.
    pub fn new(ctx: &Context, name: &str, desc: ImageDesc) -> Result<Image> {
        if desc.width == 0 || desc.height == 0 || desc.layers == 0 {
            return Err(Error::Invalid(format!(
                "{name}: an empty image ({} x {} x {})",
                desc.width, desc.height, desc.layers
            )));
        }
        assert!(!desc.cube || (desc.layers == 6 && desc.width == desc.height));
        let s = &ctx.shared;
        let (max, what) = if desc.cube {
            (s.info.max_image_dimension_cube, "cube face")
        } else {
            (s.info.max_image_dimension_2d, "image side")
        };
        if desc.width > max || desc.height > max {
            return Err(Error::Invalid(format!(
                "{name}: {} x {} exceeds the device's largest {what} ({max})",
                desc.width, desc.height
            )));
        }
        let info = desc.create_info();
        // SAFETY: valid device and create info.
        let raw = unsafe { s.device.create_image(&info, None) }.vk("creating an image")?;
        s.track();
        let mut image = Image::wrap(s, name, raw, desc, Usage::Undefined, true);
        s.name(raw, name);
        // SAFETY: raw is a live image of this device.
        let requirements = unsafe { s.device.get_image_memory_requirements(raw) };
        let allocation = allocate(s, name, requirements, MemoryLocation::GpuOnly, false)?;
        // SAFETY: the allocation satisfies the image's requirements and outlives it (Drop).
        unsafe {
            s.device
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
        }
        .vk("binding image memory")?;
        image.allocation = Some(allocation);
        image.make_views(name)?;
        Ok(image)
    }

    /// Wraps an image the caller created (an engine's render target, say) so that passes can
    /// read or write it. envlight makes its own views of it and destroys only those; `current`
    /// is how the caller's last command before envlight's used it (its layout), and after
    /// recording, [`Image::usage`] says how envlight's last command left it.
    ///
    /// # Safety
    /// `raw` must be a live image of `ctx`'s device created as `desc` says (2D, its format,
    /// extent, layers, MIP levels, usage flags, cube compatible when `desc.cube`), and must
    /// outlive the returned value and every submission that uses it.
    pub unsafe fn from_raw(
        ctx: &Context,
        name: &str,
        raw: vk::Image,
        desc: ImageDesc,
        current: Usage,
    ) -> Result<Image> {
        assert!(desc.width > 0 && desc.height > 0 && desc.layers > 0 && desc.mips > 0);
        assert!(!desc.cube || (desc.layers == 6 && desc.width == desc.height));
        ctx.shared.track();
        let mut image = Image::wrap(&ctx.shared, name, raw, desc, current, false);
        image.make_views(name)?;
        Ok(image)
    }

    /// An image value around `raw`, with no memory and no views yet.
    fn wrap(
        shared: &Arc<Shared>,
        name: &str,
        raw: vk::Image,
        desc: ImageDesc,
        state: Usage,
        owned: bool,
    ) -> Image {
        Image {
            shared: shared.clone(),
            raw,
            serial: super::context::next_serial(),
            allocation: None,
            view: vk::ImageView::null(),
            cube_view: vk::ImageView::null(),
            level_views: Vec::new(),
            name: name.to_owned(),
            desc,
            state: Mutex::new(state),
            owned,
        }
    }

    fn make_views(&mut self, name: &str) -> Result<()> {
        let desc = self.desc;
        let image = self;
        image.view = image.make_view(
            vk::ImageViewType::TYPE_2D_ARRAY,
            desc.layers,
            0,
            desc.mips,
            name,
        )?;
        if desc.cube {
            image.cube_view = image.make_view(vk::ImageViewType::CUBE, 6, 0, desc.mips, name)?;
        }
        if desc.mips > 1 {
            for level in 0..desc.mips {
                let v = image.make_view(
                    vk::ImageViewType::TYPE_2D_ARRAY,
                    desc.layers,
                    level,
                    1,
                    &format!("{name} level {level}"),
                )?;
                image.level_views.push(v);
            }
        }
        Ok(())
    }

    /// How the last command recorded so far left it (its layout and the stage that used it).
    pub fn usage(&self) -> Usage {
        *self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn make_view(
        &self,
        ty: vk::ImageViewType,
        layers: u32,
        base_level: u32,
        levels: u32,
        name: &str,
    ) -> Result<vk::ImageView> {
        let info = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(ty)
            .format(self.desc.format)
            .subresource_range(
                vk::ImageSubresourceRange::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .base_mip_level(base_level)
                    .level_count(levels)
                    .layer_count(layers),
            );
        // SAFETY: the image is live and bound to memory.
        let v = unsafe { self.shared.device.create_image_view(&info, None) }
            .vk("creating an image view")?;
        self.shared.track();
        self.shared.name(v, &format!("{name} ({ty:?} view)"));
        Ok(v)
    }

    /// The name it was created or wrapped with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The description it was created with.
    pub fn desc(&self) -> &ImageDesc {
        &self.desc
    }

    /// The raw handle.
    pub fn raw(&self) -> vk::Image {
        self.raw
    }

    /// An array view of one MIP level alone (level 0 of a single-level image is its view).
    pub(crate) fn level_view(&self, level: u32) -> vk::ImageView {
        if self.desc.mips == 1 {
            assert_eq!(level, 0);
            self.view
        } else {
            self.level_views[level as usize]
        }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let d = &self.shared.device;
        // SAFETY: every submission using this image was waited for before returning.
        unsafe {
            for v in self
                .level_views
                .drain(..)
                .chain([self.cube_view, self.view])
            {
                if v != vk::ImageView::null() {
                    d.destroy_image_view(v, None);
                    self.shared.untrack();
                }
            }
            if self.owned {
                d.destroy_image(self.raw, None);
            }
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.shared.allocator().free(a);
        }
        self.shared.untrack();
    }
}

/// A sampler.
pub struct Sampler {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Sampler,
    /// Unique in the process (descriptor caches key by it).
    pub(crate) serial: u64,
}

impl Sampler {
    /// A bilinear sampler clamping to the edge (cube views filter across faces regardless).
    pub fn linear_clamp(ctx: &Context, name: &str) -> Result<Sampler> {
        Sampler::clamped(ctx, name, vk::SamplerMipmapMode::NEAREST, 0.0)
    }

    /// A trilinear sampler clamping to the edge, over every MIP level.
    pub fn trilinear_clamp(ctx: &Context, name: &str) -> Result<Sampler> {
        Sampler::clamped(ctx, name, vk::SamplerMipmapMode::LINEAR, vk::LOD_CLAMP_NONE)
    }

    /// A trilinear sampler over every MIP level that reads transparent black beyond the
    /// image: premultiplied dual-paraboloid chains read along a direction continued past a
    /// half's rim (`dp_chain_lookup`), where repeating the edge texel would count it twice.
    pub fn trilinear_border(ctx: &Context, name: &str) -> Result<Sampler> {
        Sampler::border(ctx, name, vk::SamplerMipmapMode::LINEAR)
    }

    /// [`Sampler::trilinear_border`] reading the one MIP level nearest the lod (mipmap mode
    /// NEAREST): a bilinear read where the trilinear one blends two levels.
    pub fn nearest_mip_border(ctx: &Context, name: &str) -> Result<Sampler> {
        Sampler::border(ctx, name, vk::SamplerMipmapMode::NEAREST)
    }

    /// Bilinear within a level, `mipmap` between levels, every level, transparent black
    /// beyond the image.
    fn border(ctx: &Context, name: &str, mipmap: vk::SamplerMipmapMode) -> Result<Sampler> {
        Sampler::create(
            ctx,
            name,
            mipmap,
            vk::LOD_CLAMP_NONE,
            vk::SamplerAddressMode::CLAMP_TO_BORDER,
        )
    }

    fn clamped(
        ctx: &Context,
        name: &str,
        mipmap: vk::SamplerMipmapMode,
        max_lod: f32,
    ) -> Result<Sampler> {
        Sampler::create(
            ctx,
            name,
            mipmap,
            max_lod,
            vk::SamplerAddressMode::CLAMP_TO_EDGE,
        )
    }

    fn create(
        ctx: &Context,
        name: &str,
        mipmap: vk::SamplerMipmapMode,
        max_lod: f32,
        address: vk::SamplerAddressMode,
    ) -> Result<Sampler> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(mipmap)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .border_color(vk::BorderColor::FLOAT_TRANSPARENT_BLACK)
            .max_lod(max_lod);
        // SAFETY: valid device and create info.
        let raw =
            unsafe { ctx.shared.device.create_sampler(&info, None) }.vk("creating a sampler")?;
        ctx.shared.track();
        ctx.shared.name(raw, name);
        Ok(Sampler {
            shared: ctx.shared.clone(),
            raw,
            serial: super::context::next_serial(),
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        // SAFETY: no pending work uses it (passes wait for their submissions).
        unsafe { self.shared.device.destroy_sampler(self.raw, None) };
        self.shared.untrack();
    }
}
