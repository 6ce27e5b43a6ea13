//! GPU frame time from timestamp queries: a timestamp at the
//! beginning and at the end of every render pass of a frame, resolved into
//! a buffer and read back after the frame; the frame's GPU time is the last
//! end minus the first beginning, in the queue's timestamp period. Only on
//! an adapter with `TIMESTAMP_QUERY` (lavapipe has it; where it is missing
//! the callers fall back to submit-to-read-back wall time and say so).

use std::time::Duration;

/// Two timestamps per render pass.
pub struct Timer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    capacity: u32,
}

impl Timer {
    /// A timer for frames of at most `passes` render passes; `None` when
    /// the device has no timestamp queries.
    pub fn new(device: &wgpu::Device, passes: usize) -> Option<Timer> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let capacity = (2 * passes.max(1)) as u32;
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("shadec frame timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let size = u64::from(capacity) * 8;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadec timestamps resolve"),
            size,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadec timestamps read"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Some(Timer { queries, resolve, read, capacity })
    }

    /// The writes of render pass `index` (`None` past the capacity).
    pub fn writes(&self, index: usize) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let begin = 2 * index as u32;
        (begin + 1 < self.capacity).then_some(wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(begin),
            end_of_pass_write_index: Some(begin + 1),
        })
    }

    /// Resolves the timestamps of the `passes` render passes just recorded.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder, passes: usize) {
        let count = (2 * passes as u32).min(self.capacity);
        if count == 0 {
            return;
        }
        encoder.resolve_query_set(&self.queries, 0..count, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, u64::from(count) * 8);
    }

    /// The frame's GPU time, after the submission completed (the caller
    /// has polled the device); `None` when it cannot be read.
    pub fn elapsed(&self, device: &wgpu::Device, queue: &wgpu::Queue, passes: usize) -> Option<Duration> {
        let count = (2 * passes).min(self.capacity as usize);
        if count == 0 {
            return None;
        }
        let slice = self.read.slice(..count as u64 * 8);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |res| {
            let _ = sender.send(res);
        });
        device.poll(wgpu::PollType::wait_indefinitely()).ok()?;
        receiver.recv().ok()?.ok()?;
        let ticks: Vec<u64> = {
            let mapped = slice.get_mapped_range().ok()?;
            mapped
                .chunks_exact(8)
                .map(|b| {
                    let mut word = [0u8; 8];
                    word.copy_from_slice(b);
                    u64::from_le_bytes(word)
                })
                .collect()
        };
        self.read.unmap();
        let (first, last) = (ticks.first()?, ticks.last()?);
        let ns = last.checked_sub(*first)? as f64 * f64::from(queue.get_timestamp_period());
        Some(Duration::from_nanos(ns as u64))
    }
}
