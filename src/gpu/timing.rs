//! GPU timing with timestamp queries: labelled spans recorded into a command buffer, read
//! back once it has completed.

use super::barrier::full_barrier;
use super::context::Shared;
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

/// GPU milliseconds of `timings` together.
pub fn total_ms(timings: &[Timing]) -> f64 {
    timings.iter().map(|t| t.ms).sum()
}

/// What a submitted piece of work returned, with the GPU time of each span it recorded.
#[derive(Clone, Debug)]
pub struct Timed<T> {
    /// What the work returned.
    pub value: T,
    /// The GPU time of each labelled span, in recording order.
    pub timings: Vec<Timing>,
}

impl<T> Timed<T> {
    /// `value`, with the time of its spans.
    pub fn new(value: T, timings: Vec<Timing>) -> Timed<T> {
        Timed { value, timings }
    }

    /// GPU milliseconds of every span together.
    pub fn ms(&self) -> f64 {
        total_ms(&self.timings)
    }

    /// The same spans with `f` applied to the value.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Timed<U> {
        Timed {
            value: f(self.value),
            timings: self.timings,
        }
    }
}

/// Spans per query pool; more spans take more pools.
const POOL_SPANS: u32 = 64;

/// Timestamp query pools holding labelled spans, grown a pool at a time while recording.
pub(crate) struct Timestamps {
    shared: Arc<Shared>,
    pools: Vec<vk::QueryPool>,
    labels: Vec<String>,
    /// Spans begun and not yet ended.
    open: Vec<usize>,
}

impl Timestamps {
    pub(crate) fn new(shared: &Arc<Shared>) -> Timestamps {
        Timestamps {
            shared: shared.clone(),
            pools: Vec::new(),
            labels: Vec::new(),
            open: Vec::new(),
        }
    }

    fn stamp(&self, cmd: vk::CommandBuffer, index: u32) {
        let pool = self.pools[(index / (2 * POOL_SPANS)) as usize];
        let d = &self.shared.device;
        // SAFETY: cmd is recording; the query was reset in this command buffer.
        unsafe {
            d.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                pool,
                index % (2 * POOL_SPANS),
            )
        };
        // The full barrier keeps lavapipe (Mesa 22.3) from reordering the stamp past a dispatch.
        let bs = [full_barrier()];
        let dep = vk::DependencyInfo::default().memory_barriers(&bs);
        // SAFETY: cmd is recording.
        unsafe { d.cmd_pipeline_barrier2(cmd, &dep) };
    }

    /// Starts a span (outside a render pass).
    pub(crate) fn begin(&mut self, cmd: vk::CommandBuffer, label: &str) -> Result<()> {
        let i = self.labels.len() as u32;
        if i == self.pools.len() as u32 * POOL_SPANS {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(2 * POOL_SPANS);
            let d = &self.shared.device;
            // SAFETY: valid device and create info.
            let pool = unsafe { d.create_query_pool(&info, None) }
                .vk("creating a timestamp query pool")?;
            self.shared.track();
            self.shared.name(pool, "envlight timestamps");
            // SAFETY: cmd is recording, outside a render pass.
            unsafe { d.cmd_reset_query_pool(cmd, pool, 0, 2 * POOL_SPANS) };
            self.pools.push(pool);
        }
        self.labels.push(label.to_string());
        self.open.push(i as usize);
        self.stamp(cmd, 2 * i);
        Ok(())
    }

    /// Spans begun so far.
    pub(crate) fn len(&self) -> usize {
        self.labels.len()
    }

    /// Ends the innermost open span.
    pub(crate) fn end(&mut self, cmd: vk::CommandBuffer) {
        let i = self.open.pop().expect("end() without begin()");
        self.stamp(cmd, 2 * i as u32 + 1);
    }

    /// The spans' times, once the command buffer has completed.
    pub(crate) fn read(&self) -> Result<Vec<Timing>> {
        assert!(self.open.is_empty(), "a timing span was never ended");
        let n = self.labels.len();
        let mut ticks = vec![0u64; 2 * n];
        for (k, pool) in self.pools.iter().enumerate() {
            let first = 2 * k * POOL_SPANS as usize;
            let count = (2 * n - first).min(2 * POOL_SPANS as usize);
            // SAFETY: the queries were written by a completed submission.
            unsafe {
                self.shared.device.get_query_pool_results(
                    *pool,
                    0,
                    &mut ticks[first..first + count],
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .vk("reading timestamps")?;
        }
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

impl Drop for Timestamps {
    fn drop(&mut self) {
        for pool in self.pools.drain(..) {
            // SAFETY: the submission using the pool has completed (Recorded's contract).
            unsafe { self.shared.device.destroy_query_pool(pool, None) };
            self.shared.untrack();
        }
    }
}
