//! Appends buffers to a file on a thread of its own, so that the build's cores never wait for
//! the disk (the scene file and the spill are written while the next blocks are made).

use std::io::Write;
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Buffers in flight: a few megabytes of blocks.
const QUEUE: usize = 64;

pub struct Appender {
    tx: Option<SyncSender<Vec<u8>>>,
    thread: Option<JoinHandle<std::io::Result<std::fs::File>>>,
}

impl Appender {
    pub fn new(file: std::fs::File) -> Appender {
        let (tx, rx) = sync_channel::<Vec<u8>>(QUEUE);
        let thread = std::thread::spawn(move || {
            let mut w = std::io::BufWriter::with_capacity(1 << 22, file);
            for bytes in rx {
                w.write_all(&bytes)?;
            }
            w.into_inner().map_err(|e| e.into_error())
        });
        Appender { tx: Some(tx), thread: Some(thread) }
    }

    /// Queues `bytes`; an error of an earlier write comes back here or from `finish`.
    pub fn append(&mut self, bytes: Vec<u8>) -> std::io::Result<()> {
        if self.tx.as_ref().expect("open until finished").send(bytes).is_err() {
            // The writer stopped: it failed, and says why when joined.
            return Err(self.join().err().unwrap_or_else(|| std::io::Error::other("the writer thread stopped")));
        }
        Ok(())
    }

    /// Waits for every queued write; returns the file, flushed.
    pub fn finish(mut self) -> std::io::Result<std::fs::File> {
        self.join()
    }

    fn join(&mut self) -> std::io::Result<std::fs::File> {
        self.tx = None;
        let thread = self.thread.take().ok_or_else(|| std::io::Error::other("the writer thread already ended"))?;
        thread.join().map_err(|_| std::io::Error::other("the writer thread panicked"))?
    }
}

impl Drop for Appender {
    fn drop(&mut self) {
        if self.thread.is_some() {
            let _ = self.join();
        }
    }
}
