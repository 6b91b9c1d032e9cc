//! GPU timing with timestamp queries.

use super::barrier::{cmd_memory_barrier, full_barrier};
use super::context::{Context, Shared};
use crate::error::{Result, VkContext};
use ash::vk;
use std::sync::Arc;

/// The GPU time one labelled span of a pass took.
#[derive(Clone, Debug, PartialEq)]
pub struct Timing {
    /// What was timed.
    pub label: String,
    /// Milliseconds between the span's two timestamps.
    pub ms: f64,
}

/// A pool of timestamp queries recording labelled spans within one command buffer.
pub struct GpuTimer {
    shared: Arc<Shared>,
    pool: vk::QueryPool,
    capacity: u32,
    labels: Vec<String>,
}

impl GpuTimer {
    /// A timer for up to `spans` spans, or `None` where the queue has no timestamps.
    pub fn new(ctx: &Context, spans: u32) -> Result<Option<GpuTimer>> {
        if ctx.info().timestamp_valid_bits == 0 {
            return Ok(None);
        }
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(spans * 2);
        // SAFETY: valid device and create info.
        let pool = unsafe { ctx.shared.device.create_query_pool(&info, None) }
            .vk("creating a timestamp query pool")?;
        ctx.shared.track();
        ctx.shared.name(pool, "envlight timestamps");
        Ok(Some(GpuTimer {
            shared: ctx.shared.clone(),
            pool,
            capacity: spans,
            labels: Vec::new(),
        }))
    }

    /// Resets the queries; record this before the first span.
    pub fn reset(&mut self, cmd: vk::CommandBuffer) {
        self.labels.clear();
        // SAFETY: cmd is recording, outside a render pass.
        unsafe {
            self.shared
                .device
                .cmd_reset_query_pool(cmd, self.pool, 0, self.capacity * 2)
        };
    }

    fn stamp(&self, cmd: vk::CommandBuffer, query: u32) {
        // SAFETY: cmd is recording; the query was reset in this command buffer.
        unsafe {
            self.shared.device.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
        // The full barrier keeps lavapipe (Mesa 22.3) from reordering the stamp past a dispatch.
        cmd_memory_barrier(&self.shared.device, cmd, full_barrier());
    }

    /// Starts a span; returns its index for [`GpuTimer::end`].
    pub fn begin(&mut self, cmd: vk::CommandBuffer, label: &str) -> usize {
        let i = self.labels.len();
        assert!((i as u32) < self.capacity, "GpuTimer capacity exceeded");
        self.labels.push(label.to_string());
        self.stamp(cmd, 2 * i as u32);
        i
    }

    /// Ends a span.
    pub fn end(&mut self, cmd: vk::CommandBuffer, span: usize) {
        self.stamp(cmd, 2 * span as u32 + 1);
    }

    /// Reads the spans back (after the command buffer has completed).
    pub fn read(&self) -> Result<Vec<Timing>> {
        let n = self.labels.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let mut ticks = vec![0u64; 2 * n];
        // SAFETY: the queries were written by a completed submission.
        unsafe {
            self.shared.device.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("reading timestamps")?;
        let bits = self.shared.info.timestamp_valid_bits;
        let mask = if bits >= 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        let period = self.shared.info.timestamp_period;
        Ok(self
            .labels
            .iter()
            .enumerate()
            .map(|(i, label)| {
                let dt = ticks[2 * i + 1].wrapping_sub(ticks[2 * i]) & mask;
                Timing {
                    label: label.clone(),
                    ms: dt as f64 * period * 1e-6,
                }
            })
            .collect())
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        // SAFETY: the submission using the pool has completed.
        unsafe { self.shared.device.destroy_query_pool(self.pool, None) };
        self.shared.untrack();
    }
}

/// A [`GpuTimer`] where the device has timestamps, and nothing where it has none: passes record
/// spans through it without caring which.
pub struct Spans(Option<GpuTimer>);

impl Spans {
    /// Room for `spans` spans.
    pub fn new(ctx: &Context, spans: u32) -> Result<Spans> {
        Ok(Spans(GpuTimer::new(ctx, spans)?))
    }

    /// Resets the queries; record first in the command buffer.
    pub fn reset(&mut self, cmd: vk::CommandBuffer) {
        if let Some(t) = self.0.as_mut() {
            t.reset(cmd);
        }
    }

    /// Starts a span.
    pub fn begin(&mut self, cmd: vk::CommandBuffer, label: &str) -> Option<usize> {
        self.0.as_mut().map(|t| t.begin(cmd, label))
    }

    /// Ends a span started by [`Spans::begin`].
    pub fn end(&mut self, cmd: vk::CommandBuffer, span: Option<usize>) {
        if let (Some(t), Some(s)) = (self.0.as_mut(), span) {
            t.end(cmd, s);
        }
    }

    /// The spans' times, after the submission completed (empty without timestamps).
    pub fn read(&self) -> Result<Vec<Timing>> {
        match &self.0 {
            Some(t) => t.read(),
            None => Ok(Vec::new()),
        }
    }
}
