//! SH shading of arbitrary BRDFs (Kautz, Sloan & Snyder 2002): the projection of a BRDF onto
//! SH per view of a grid (`glsl/sh_brdf.comp`, float64 twin `crate::math::sh_brdf`), and the
//! rotation of SH vectors by either construction (`glsl/sh_rotate.comp`, twin
//! `crate::math::sh_rotate`) that the shading pass uses per pixel and tests check alone.

use crate::abi::{binding, push::ShBrdfPush, push::ShRotatePush, sh_brdf, ShaderId};
use crate::abi::{SH_MAX_LMAX, WORKGROUP_1D};
use crate::error::{Error, Result};
use crate::gpu::{groups, Bind, Buffer, Context, Pipeline, Recorder, Timed, Usage};
use crate::math::brdf::Brdf;
use crate::math::sh::count;
pub use crate::math::sh_brdf::ViewGrid;
use crate::math::sh_rotate::x90;
use crate::passes::testing::poison::{self, PassId};
use ash::vk;
use glam::DMat3;
use gpu_allocator::MemoryLocation;
use std::sync::OnceLock;

/// BRDF ids the projection is specialised on (`abi::brdf::ids`).
const BRDFS: usize = 6;
const VARIANTS: usize = (SH_MAX_LMAX as usize + 1) * BRDFS;

/// How SH vectors are rotated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rotation {
    /// Kautz et al.'s zxzxz decomposition (the default: both rotations stay within 1e-6 of
    /// float64 at l = 8 in f32, and this one does less work; docs/techniques.md).
    Zxzxz,
    /// The Ivanic–Ruedenberg recurrence.
    Ivanic,
}

impl Rotation {
    /// The id the shaders know it by.
    pub fn id(self) -> u32 {
        match self {
            Rotation::Zxzxz => sh_brdf::ROTATION_ZXZXZ,
            Rotation::Ivanic => sh_brdf::ROTATION_IVANIC,
        }
    }
}

/// The fixed blocks of M(Rx(90°)) to band 8, as the shaders read them (bands in order,
/// row-major, f32).
pub fn x90_buffer(ctx: &Context) -> Result<Buffer> {
    let data: Vec<f32> = x90(SH_MAX_LMAX)
        .bands
        .iter()
        .flatten()
        .map(|&v| v as f32)
        .collect();
    Buffer::storage(ctx, "sh rotation: M(Rx(90°))", &data)
}

/// The BRDF projection pass.
pub struct ShBrdfProjector {
    ctx: Context,
    pipelines: [OnceLock<Pipeline>; VARIANTS],
}

impl ShBrdfProjector {
    /// Creates the pass; its pipelines (one per band and BRDF) are built on first use.
    pub fn new(ctx: &Context) -> ShBrdfProjector {
        ShBrdfProjector {
            ctx: ctx.clone(),
            pipelines: std::array::from_fn(|_| OnceLock::new()),
        }
    }

    /// Floats one table of band `lmax` over `grid` takes.
    pub fn table_floats(lmax: u32, grid: ViewGrid) -> usize {
        (grid.size * grid.size) as usize * count(lmax)
    }

    fn pipeline(&self, lmax: u32, brdf: u32) -> Result<&Pipeline> {
        let cell = &self.pipelines[lmax as usize * BRDFS + brdf as usize];
        if cell.get().is_none() {
            let p = Pipeline::compute(&self.ctx, ShaderId::ShBrdf, &[WORKGROUP_1D, lmax, brdf])?;
            let _ = cell.set(p);
        }
        Ok(cell.get().unwrap_or_else(|| unreachable!("set above")))
    }

    /// Records the table of `brdf` to band `lmax` over `grid` into `out` from float `offset`
    /// on (view after view, row-major, `count``(lmax)` floats each). Span: "sh brdf table".
    pub fn record(
        &self,
        rec: &mut Recorder,
        brdf: &Brdf,
        lmax: u32,
        grid: ViewGrid,
        out: &Buffer,
        offset: u32,
    ) -> Result<()> {
        if lmax > SH_MAX_LMAX || !(1..=sh_brdf::MAX_GRID).contains(&grid.size) {
            return Err(Error::Invalid(format!(
                "sh_brdf: band {lmax} (0 to {SH_MAX_LMAX}) or grid {} (1 to {}) out of range",
                grid.size,
                sh_brdf::MAX_GRID
            )));
        }
        let need = (offset as u64 + Self::table_floats(lmax, grid) as u64) * 4;
        assert!(
            need <= out.size(),
            "sh_brdf: the output buffer is too small"
        );
        let p = brdf.params();
        let pipeline = self.pipeline(lmax, brdf.id())?;
        rec.span("sh brdf table", |rec| {
            // One dispatch per panel of the first uniform (llvmpipe's loop limit).
            for panel in 0..2 * sh_brdf::GRADED_LEVELS {
                let push = ShBrdfPush {
                    grid: grid.size,
                    p0: p[0] as f32,
                    p1: p[1] as f32,
                    offset,
                    panel,
                    pad: [0; 3],
                };
                rec.dispatch(
                    pipeline,
                    &[(binding::SH_BRDF_TABLE, Bind::Buffer(out))],
                    &push,
                    [groups(grid.size * grid.size, WORKGROUP_1D), 1, 1],
                )?;
            }
            Ok(())
        })?;
        let (floats, coeffs) = (Self::table_floats(lmax, grid), crate::math::sh::count(lmax));
        let f = poison::Floats::sh(offset, floats as u32, 1, coeffs as u32);
        poison::buffer(rec, PassId::ShBrdf, out, f)
    }

    /// Computes one table and reads it back.
    pub fn run(&self, brdf: &Brdf, lmax: u32, grid: ViewGrid) -> Result<Timed<Vec<f32>>> {
        let n = Self::table_floats(lmax, grid);
        let out = Buffer::new(
            &self.ctx,
            "sh brdf table",
            n as u64 * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let t = self
            .ctx
            .run("projecting a BRDF onto SH", |rec| {
                self.record(rec, brdf, lmax, grid, &out, 0)?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        Ok(Timed::new(out.read(n), t))
    }
}

/// The rotation pass: rotates SH vectors on the GPU.
pub struct ShRotator {
    ctx: Context,
    pipeline: Pipeline,
    x90: Buffer,
}

impl ShRotator {
    /// Builds the pipeline and uploads the fixed blocks.
    pub fn new(ctx: &Context) -> Result<ShRotator> {
        Ok(ShRotator {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::ShRotate, &[WORKGROUP_1D])?,
            x90: x90_buffer(ctx)?,
        })
    }

    /// Rotates each vector (of (lmax+1)² coefficients) by its rotation with `method`; returns
    /// the rotated vectors and the GPU time ("sh rotate").
    pub fn run(
        &self,
        method: Rotation,
        lmax: u32,
        items: &[(DMat3, Vec<f64>)],
    ) -> Result<Timed<Vec<Vec<f32>>>> {
        let nc = count(lmax);
        assert!(lmax <= SH_MAX_LMAX && !items.is_empty());
        let mut data: Vec<f32> =
            Vec::with_capacity(items.len() * (sh_brdf::ROTATE_HEADER as usize + nc));
        for (r, c) in items {
            assert_eq!(c.len(), nc, "a vector of the wrong length");
            for i in 0..3 {
                let row = r.row(i);
                data.extend([row.x as f32, row.y as f32, row.z as f32, 0.0]);
            }
            data.extend(c.iter().map(|&v| v as f32));
        }
        let input = Buffer::storage(&self.ctx, "sh rotate input", &data)?;
        let out = Buffer::new(
            &self.ctx,
            "sh rotate output",
            (items.len() * nc * 4) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let push = ShRotatePush {
            count: items.len() as u32,
            lmax,
            method: method.id(),
            pad: 0,
        };
        let t = self
            .ctx
            .run("rotating SH vectors", |rec| {
                rec.span("sh rotate", |rec| {
                    rec.dispatch(
                        &self.pipeline,
                        &[
                            (binding::SH_ROT_IN, Bind::Buffer(&input)),
                            (binding::SH_ROT_OUT, Bind::Buffer(&out)),
                            (binding::SH_ROT_X90, Bind::Buffer(&self.x90)),
                        ],
                        &push,
                        [groups(items.len() as u32, WORKGROUP_1D), 1, 1],
                    )
                })?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        let flat: Vec<f32> = out.read(items.len() * nc);
        Ok(Timed::new(
            flat.chunks_exact(nc).map(<[f32]>::to_vec).collect(),
            t,
        ))
    }
}
