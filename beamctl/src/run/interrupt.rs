//! A caller's "stop now?" question (the Python package's Ctrl-C), asked
//! from a long computation at a bounded rate.

/// Units of work (evaluations, samples) between two questions.
pub const ASK_EVERY: u64 = 4096;

/// Counts units of work and asks the caller's callback every
/// [`ASK_EVERY`] of them; once it has said stop, it keeps saying so.
pub struct Interrupt<'a> {
    ask: Option<&'a mut dyn FnMut() -> bool>,
    work: u64,
    fired: bool,
}

impl<'a> Interrupt<'a> {
    /// `ask: None` never stops.
    pub fn new(ask: Option<&'a mut dyn FnMut() -> bool>) -> Self {
        Self {
            ask,
            work: 0,
            fired: false,
        }
    }

    /// One unit of work done: whether to stop now.
    pub fn stopped(&mut self) -> bool {
        if self.fired {
            return true;
        }
        self.work += 1;
        if let Some(ask) = self.ask.as_deref_mut() {
            if self.work.is_multiple_of(ASK_EVERY) {
                self.fired = ask();
            }
        }
        self.fired
    }

    /// Whether the caller has said stop.
    pub fn fired(&self) -> bool {
        self.fired
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn asks_every_ask_every_units_and_stays_stopped() {
        let mut asked = 0;
        let mut ask = || {
            asked += 1;
            asked == 2
        };
        let mut i = Interrupt::new(Some(&mut ask));
        let stops: Vec<u64> = (1..=3 * ASK_EVERY).filter(|_| i.stopped()).collect();
        assert!(i.fired());
        assert_eq!(stops.first(), Some(&(2 * ASK_EVERY)));
        assert_eq!(stops.len() as u64, ASK_EVERY + 1);
        assert_eq!(asked, 2);
    }

    #[test]
    fn without_a_callback_never_stops() {
        let mut i = Interrupt::new(None);
        assert!(!(0..3 * ASK_EVERY).any(|_| i.stopped()));
        assert!(!i.fired());
    }
}
