//! A port that logs what it receives (shared by the test binaries that measure wire timing).

/// A port that logs every character it receives with its arrival time.
pub struct Tap<IO> {
    /// The port.
    pub inner: IO,
    /// What arrived.
    pub log: std::sync::Arc<std::sync::Mutex<Vec<drive_core::rt::ReceivedChar>>>,
}

impl<IO: drive_core::rt::CharIo> drive_core::rt::CharIo for Tap<IO> {
    fn poll_read_chars(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &mut [drive_core::rt::ReceivedChar],
    ) -> std::task::Poll<std::io::Result<usize>> {
        let r = self.inner.poll_read_chars(cx, buf);
        if let std::task::Poll::Ready(Ok(n)) = r {
            self.log.lock().unwrap().extend_from_slice(&buf[..n]);
        }
        r
    }
    fn poll_write(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
    ) -> std::task::Poll<std::io::Result<usize>> {
        self.inner.poll_write(cx, buf)
    }
    fn poll_flush(
        &mut self,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        self.inner.poll_flush(cx)
    }
    fn poll_write_at(
        &mut self,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
        start: tokio::time::Instant,
    ) -> std::task::Poll<std::io::Result<usize>> {
        self.inner.poll_write_at(cx, buf, start)
    }

    fn honours_write_start(&self) -> bool {
        self.inner.honours_write_start()
    }

    fn wire_time(&self) -> drive_core::rt::WireTime {
        self.inner.wire_time()
    }
}
