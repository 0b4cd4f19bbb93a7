//! A bounded reorder buffer: puts rows that arrive slightly out of order back
//! in time order, drops exact duplicates, and drops (and counts) rows that
//! arrive later than the window allows.

use std::collections::{BTreeMap, VecDeque};

use fpbp_core::events::LogEvent;

/// What happened to a pushed event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Buffered, in order.
    InOrder,
    /// Buffered, but it is earlier than an event pushed before it.
    Backwards,
    /// An exact duplicate of a buffered or recently emitted event: dropped.
    Duplicate,
    /// Earlier than an event already emitted: dropped.
    TooLate,
}

/// Events wait here until the newest pushed time is `window_ns` past them.
#[derive(Debug)]
pub struct ReorderBuffer {
    window_ns: i64,
    buf: BTreeMap<(i64, u64), LogEvent>,
    seq: u64,
    max_pushed: Option<i64>,
    /// Emitted events still within the window (for duplicate checks of late rows).
    recent: VecDeque<LogEvent>,
    last_emitted: Option<i64>,
}

impl ReorderBuffer {
    pub fn new(window_ns: i64) -> Self {
        ReorderBuffer {
            window_ns: window_ns.max(0),
            buf: BTreeMap::new(),
            seq: 0,
            max_pushed: None,
            recent: VecDeque::new(),
            last_emitted: None,
        }
    }

    /// Adds one event.
    pub fn push(&mut self, e: LogEvent) -> Pushed {
        let t = e.t_ns();
        let same_t_dup = self.buf.range((t, 0)..=(t, u64::MAX)).any(|(_, b)| *b == e)
            || self
                .recent
                .iter()
                .rev()
                .take_while(|r| r.t_ns() >= t)
                .any(|r| *r == e);
        if same_t_dup {
            return Pushed::Duplicate;
        }
        if self.last_emitted.is_some_and(|l| t < l) {
            return Pushed::TooLate;
        }
        let backwards = self.max_pushed.is_some_and(|m| t < m);
        self.max_pushed = Some(self.max_pushed.map_or(t, |m| m.max(t)));
        self.buf.insert((t, self.seq), e);
        self.seq += 1;
        if backwards {
            Pushed::Backwards
        } else {
            Pushed::InOrder
        }
    }

    /// The next event that can no longer be overtaken, if any.
    pub fn pop_ready(&mut self) -> Option<LogEvent> {
        let max = self.max_pushed?;
        let (&(t, _), _) = self.buf.first_key_value()?;
        if t.saturating_add(self.window_ns) <= max {
            self.pop_first()
        } else {
            None
        }
    }

    /// The next event regardless of the window (at end of input).
    pub fn pop_any(&mut self) -> Option<LogEvent> {
        self.pop_first()
    }

    fn pop_first(&mut self) -> Option<LogEvent> {
        let (_, e) = self.buf.pop_first()?;
        let t = e.t_ns();
        self.last_emitted = Some(t);
        self.recent.push_back(e.clone());
        while self
            .recent
            .front()
            .is_some_and(|r| r.t_ns() < t.saturating_sub(self.window_ns))
        {
            self.recent.pop_front();
        }
        Some(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::events::TruthPoint;

    fn tp(t_ns: i64, x: f64) -> LogEvent {
        LogEvent::Truth(TruthPoint {
            t_ns,
            x_m: x,
            y_m: 0.0,
            floor: None,
        })
    }

    #[test]
    fn reorders_within_window_and_drops_late_and_duplicates() {
        let mut r = ReorderBuffer::new(10);
        assert_eq!(r.push(tp(0, 0.0)), Pushed::InOrder);
        assert_eq!(r.push(tp(5, 1.0)), Pushed::InOrder);
        assert_eq!(r.push(tp(3, 2.0)), Pushed::Backwards);
        assert_eq!(r.push(tp(5, 1.0)), Pushed::Duplicate);
        assert_eq!(r.pop_ready(), None);
        assert_eq!(r.push(tp(14, 3.0)), Pushed::InOrder);
        assert_eq!(r.pop_ready(), Some(tp(0, 0.0)));
        assert_eq!(r.pop_ready(), Some(tp(3, 2.0)));
        assert_eq!(r.pop_ready(), None);
        assert_eq!(r.push(tp(1, 9.0)), Pushed::TooLate);
        assert_eq!(r.push(tp(3, 2.0)), Pushed::Duplicate);
        let rest: Vec<_> = std::iter::from_fn(|| r.pop_any()).collect();
        assert_eq!(rest, vec![tp(5, 1.0), tp(14, 3.0)]);
    }
}
