//! A byte-stream link (a TCP connection or a serial port): a reader feeding the hub and a writer
//! draining the link's bounded queue.

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::sync::mpsc;

use super::{LinkSigning, Shared};
use crate::frame::FrameParser;
use crate::hub::Tx;
use crate::station::Station;

/// Frames a stream link may have queued for writing before new ones are dropped (and counted).
const WRITE_QUEUE: usize = 256;

/// Registers the stream as a link and runs it on its own tasks until EOF, an error or shutdown.
pub fn spawn<S: Station, R, W>(
    name: String,
    reader: R,
    writer: W,
    signing: Option<LinkSigning>,
    shared: Shared<S>,
) where
    R: AsyncRead + Unpin + Send + 'static,
    W: AsyncWrite + Unpin + Send + 'static,
{
    tokio::spawn(run(name, reader, writer, signing, shared));
}

/// Registers the stream as a link, runs it until EOF, an error or shutdown, and removes the
/// link; the writer runs on a task of its own, which ends when the link is removed.
pub async fn run<S: Station, R, W>(
    name: String,
    mut reader: R,
    mut writer: W,
    signing: Option<LinkSigning>,
    shared: Shared<S>,
) where
    R: AsyncRead + Unpin + Send + 'static,
    W: AsyncWrite + Unpin + Send + 'static,
{
    let (tx, mut rx) = mpsc::channel::<Vec<u8>>(WRITE_QUEUE);
    let id = shared.add_link(name.clone(), Tx::Stream(tx), signing);
    let shutdown = shared.shutdown.clone();
    let writer_name = name.clone();
    tokio::spawn(async move {
        loop {
            tokio::select! {
                _ = shutdown.cancelled() => break,
                bytes = rx.recv() => match bytes {
                    Some(bytes) => if let Err(e) = writer.write_all(&bytes).await {
                        tracing::warn!(link = %writer_name, error = %e, "MAVLink write failed");
                        break;
                    },
                    None => break,
                },
            }
        }
    });
    let mut parser = FrameParser::new();
    let mut buf = vec![0u8; 4096];
    let mut frames = Vec::new();
    loop {
        let n = tokio::select! {
            _ = shared.shutdown.cancelled() => break,
            r = reader.read(&mut buf) => match r {
                Ok(0) => {
                    tracing::info!(link = %name, "MAVLink stream reached end of file");
                    break;
                }
                Err(error) => {
                    tracing::warn!(link = %name, %error, "MAVLink stream read failed");
                    break;
                }
                Ok(n) => n,
            },
        };
        parser.push(&buf[..n], &mut frames);
        shared.handle_frames(id, &frames);
        frames.clear();
    }
    let stats = parser.stats();
    tracing::info!(link = %name, ?stats, "MAVLink stream closed");
    shared.hub().remove_link(id);
}
