//! A fixed-capacity FIFO for the events of sans-IO state machines (no allocation).

/// A ring buffer of at most `N` items; when full, [`Queue::push`] drops the oldest item.
///
/// ```
/// use drive_core::Queue;
/// let mut q: Queue<u8, 2> = Queue::new();
/// q.push(1);
/// q.push(2);
/// q.push(3); // drops 1
/// assert_eq!((q.pop(), q.pop(), q.pop()), (Some(2), Some(3), None));
/// ```
#[derive(Debug, Clone)]
pub struct Queue<T: Copy, const N: usize> {
    items: [Option<T>; N],
    head: usize,
    len: usize,
}

impl<T: Copy, const N: usize> Queue<T, N> {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            items: [None; N],
            head: 0,
            len: 0,
        }
    }

    /// Append `item`; when full, the oldest item is dropped to make room.
    pub fn push(&mut self, item: T) {
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

    /// Take the oldest item.
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let item = self.items.get_mut(self.head).and_then(Option::take);
        self.head = (self.head + 1) % N;
        self.len -= 1;
        item
    }

    /// Number of queued items.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is queued.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Drop every item.
    pub fn clear(&mut self) {
        while self.pop().is_some() {}
    }
}

impl<T: Copy, const N: usize> Default for Queue<T, N> {
    fn default() -> Self {
        Self::new()
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
        assert_eq!(q.len(), 3);
        assert_eq!(
            (q.pop(), q.pop(), q.pop(), q.pop()),
            (Some(2), Some(3), Some(4), None)
        );
        let mut z: Queue<u8, 0> = Queue::new();
        z.push(1);
        assert_eq!(z.pop(), None);
        q.push(9);
        q.clear();
        assert!(q.is_empty());
    }
}
