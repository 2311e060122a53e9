//! The frames' PNGs, written on a thread of their own: off the latency's path and the display's
//! loop, which only waits when the writer falls more than [`QUEUE`] frames behind.

use osw_render::output::{frame_path, write_png};
use std::path::Path;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;
use std::time::Instant;

/// Frames waiting to be written (each w x h x 4 bytes).
const QUEUE: usize = 2;

pub struct FrameWriter {
    frames: SyncSender<(u64, Vec<u8>)>,
    /// None once joined (it stopped on an error, which `write` returned).
    thread: Option<JoinHandle<anyhow::Result<()>>>,
}

impl FrameWriter {
    pub fn start(out: &Path, width: u32, height: u32) -> FrameWriter {
        let (frames, queue) = sync_channel(QUEUE);
        let out = out.to_path_buf();
        let thread = std::thread::spawn(move || write_all(&out, width, height, queue));
        FrameWriter { frames, thread: Some(thread) }
    }

    /// Queues frame i; returns how long the queue was full, in ms. When the writer has
    /// stopped on an error (a full disk, say), returns that error.
    pub fn write(&mut self, i: u64, rgba: Vec<u8>) -> anyhow::Result<f64> {
        let t = Instant::now();
        if self.frames.send((i, rgba)).is_err() {
            join(self.thread.take())?;
            anyhow::bail!("frame {i}: the frame writer stopped");
        }
        Ok(t.elapsed().as_secs_f64() * 1e3)
    }

    /// Waits for the queued frames to be written.
    pub fn finish(self) -> anyhow::Result<()> {
        let FrameWriter { frames, thread } = self;
        drop(frames);
        join(thread)
    }
}

fn join(thread: Option<JoinHandle<anyhow::Result<()>>>) -> anyhow::Result<()> {
    thread.map_or(Ok(()), |t| t.join().map_err(|_| anyhow::anyhow!("the frame writer panicked"))?)
}

fn write_all(out: &Path, width: u32, height: u32, queue: Receiver<(u64, Vec<u8>)>) -> anyhow::Result<()> {
    for (i, rgba) in queue {
        write_png(&frame_path(out, i), width, height, &rgba)?;
    }
    Ok(())
}
