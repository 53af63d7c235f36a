//! A fixed-capacity FIFO for state machine events (no allocation).

#[derive(Debug, Clone)]
pub(crate) struct Queue<T: Copy, const N: usize> {
    items: [Option<T>; N],
    head: usize,
    len: usize,
}

impl<T: Copy, const N: usize> Queue<T, N> {
    pub(crate) const fn new() -> Self {
        Self {
            items: [None; N],
            head: 0,
            len: 0,
        }
    }

    /// Append `item`; when full, the oldest item is dropped to make room.
    pub(crate) fn push(&mut self, item: T) {
        if N == 0 {
            return;
        }
        if self.len == N {
            let _ = self.pop();
        }
        let tail = (self.head + self.len) % N;
        if let Some(slot) = self.items.get_mut(tail) {
            *slot = Some(item);
            self.len += 1;
        }
    }

    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let item = self.items.get_mut(self.head).and_then(Option::take);
        self.head = (self.head + 1) % N;
        self.len -= 1;
        item
    }

    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::Queue;

    #[test]
    fn fifo_drops_oldest_when_full() {
        let mut q: Queue<u8, 3> = Queue::new();
        assert!(q.is_empty());
        for i in 0..5 {
            q.push(i);
        }
        assert_eq!(
            (q.pop(), q.pop(), q.pop(), q.pop()),
            (Some(2), Some(3), Some(4), None)
        );
    }
}
