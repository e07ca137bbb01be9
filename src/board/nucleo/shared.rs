//! State shared between the sample interrupt and thread mode.
//!
//! A [`Shared`] holds one value behind a critical section (PRIMASK): the
//! owner-of-the-moment runs a closure on it. The sample interrupt runs its
//! whole tick inside [`Shared::with`] (it is the highest priority, so the
//! mask costs nothing there); thread mode takes the same lock for the few
//! hundred cycles a setting change takes (`Pipeline::replace_estimator`,
//! `set_raw_decimation`, reading counters), which delays the next DRDY
//! interrupt by at most that long — never by a missed sample. Expensive
//! work (building an estimator, modal recovery) happens outside the lock
//! and is handed over by value.
//!
//! A `RefCell` inside the critical section would be re-borrowed only by
//! re-entering `with` from inside its own closure; [`Shared::with`] then
//! returns `None` instead of panicking.

use core::cell::RefCell;

use critical_section::Mutex;

/// One value shared between contexts (see the module doc).
pub struct Shared<T>(Mutex<RefCell<Option<T>>>);

impl<T> Shared<T> {
    /// Empty.
    pub const fn new() -> Self {
        Self(Mutex::new(RefCell::new(None)))
    }

    /// Place `value`, returning the previous one; `Err(value)` only on
    /// re-entry from inside [`Shared::with`]'s closure.
    pub fn put(&self, value: T) -> Result<Option<T>, T> {
        critical_section::with(|cs| match self.0.borrow(cs).try_borrow_mut() {
            Ok(mut slot) => Ok(slot.replace(value)),
            Err(_) => Err(value),
        })
    }

    /// Run `f` on the value under the lock; `None` if there is no value
    /// (or, only on re-entry from inside `f`, if it is borrowed).
    #[inline]
    pub fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> Option<R> {
        critical_section::with(|cs| {
            let mut slot = self.0.borrow(cs).try_borrow_mut().ok()?;
            slot.as_mut().map(f)
        })
    }
}

impl<T> Default for Shared<T> {
    fn default() -> Self {
        Self::new()
    }
}
