//! Rebuilding an estimator where it lies: firmware keeps the robust
//! estimator in static slots far larger than its stack (`f64`, 2 s: 325 KB;
//! the NUCLEO image's stack is under 128 KiB), so a new estimator cannot be
//! built by value and moved into its slot.

use core::mem::MaybeUninit;

use super::{RecordStore, RobustConfig, RobustEstimator};
use crate::estimator::ConfigError;
use crate::filter_bank::FilterConfig;
use crate::scalar::Real;

/// Everything of a robust estimator but its record (a few KB): what
/// [`RobustEstimator::new`] builds for a record of no samples, off the
/// sample path, and
/// [`RobustEstimator::install`] puts in place of a running estimator (a
/// firmware with one record slot, `src/bin/qemu-rig/device.rs`).
pub type Head<T, const D: usize, const NP: usize, const NS: usize> =
    RobustEstimator<T, D, NP, NS, 0>;

impl<
        T: Real,
        const D: usize,
        const NP: usize,
        const NS: usize,
        const B: usize,
        R: RecordStore<T>,
    > RobustEstimator<T, D, NP, NS, B, R>
{
    /// [`RobustEstimator::new`]`(filter, cfg)` written into `slot`:
    /// everything but the record is built by `new` with an empty record (a
    /// few KB) and moved in; the record is a zero literal, which the
    /// compiler writes where it lies instead of building it on the stack
    /// and copying it (a board checks its image for that: `cargo xtask
    /// firmware`'s stack-frame check).
    ///
    /// # Errors
    /// Those of [`RobustEstimator::new`]; `slot` is then not written.
    pub fn new_in<'a>(
        slot: &'a mut MaybeUninit<Self>,
        filter: &FilterConfig,
        cfg: &RobustConfig<NP>,
    ) -> Result<&'a mut Self, ConfigError> {
        Self::check_record()?;
        let RobustEstimator {
            bank,
            startup,
            oe,
            law,
            learner,
            cfg,
            filter,
            inv_u_scale,
            inv_y_scale,
            rho_pow,
            unscale,
            rec: _,
            u_step,
            rec_len,
            unrecorded,
            phase,
            epoch,
            candidate,
            adapted,
            min_adapted,
            countdown,
            frozen,
            initial,
            updates,
        } = Head::<T, D, NP, NS>::new(filter, cfg)?;
        let placed = slot.write(Self {
            bank,
            startup,
            oe,
            law,
            learner,
            cfg,
            filter,
            inv_u_scale,
            inv_y_scale,
            rho_pow,
            unscale,
            rec: R::empty(),
            u_step,
            rec_len,
            unrecorded,
            phase,
            epoch,
            candidate,
            adapted,
            min_adapted,
            countdown,
            frozen,
            initial,
            updates,
        });
        placed.rec.restart(u_step);
        Ok(placed)
    }

    /// [`RobustEstimator::new`]'s refusal of a record whose dimensions
    /// disagree, without building anything.
    fn check_record() -> Result<(), ConfigError> {
        if R::CAPACITY != B || !R::CONSISTENT {
            return Err(ConfigError::Dimensions);
        }
        Ok(())
    }

    /// Make `self` what [`RobustEstimator::new`]`(filter, cfg)` returns,
    /// in place: everything but the record is built (by `new` with an
    /// empty record, a few KB) and moved in, the record is started afresh
    /// where it lies; only the update epoch differs (advanced, so an update
    /// prepared for the estimator the slot held before is refused as
    /// stale). On an error `self` is unchanged.
    ///
    /// # Errors
    /// Those of [`RobustEstimator::new`].
    pub fn rebuild(
        &mut self,
        filter: &FilterConfig,
        cfg: &RobustConfig<NP>,
    ) -> Result<(), ConfigError> {
        Self::check_record()?;
        let head = Head::<T, D, NP, NS>::new(filter, cfg)?;
        self.install(&head);
        Ok(())
    }

    /// Make `self` the estimator `head` stands for, with an empty record:
    /// [`RobustEstimator::rebuild`] with the head built beforehand (inside a
    /// lock this is a copy of a few KB; the record is not touched beyond
    /// its running sums). The update epoch advances, as in `rebuild`.
    pub fn install(&mut self, head: &Head<T, D, NP, NS>) {
        // Every field named: a field added to the estimator fails to
        // compile here until it is installed too.
        let RobustEstimator {
            bank,
            startup,
            oe,
            law,
            learner,
            cfg,
            filter,
            inv_u_scale,
            inv_y_scale,
            rho_pow,
            unscale,
            rec: _,
            u_step,
            rec_len,
            unrecorded,
            phase,
            epoch: _,
            candidate,
            adapted,
            min_adapted,
            countdown,
            frozen,
            initial,
            updates,
        } = head;
        self.bank = bank.clone();
        self.startup = startup.clone();
        self.oe = oe.clone();
        self.law = law.clone();
        self.learner = learner.clone();
        self.cfg = *cfg;
        self.filter = *filter;
        self.inv_u_scale = *inv_u_scale;
        self.inv_y_scale = *inv_y_scale;
        self.rho_pow = *rho_pow;
        self.unscale = *unscale;
        self.rec.restart(*u_step);
        self.u_step = *u_step;
        self.rec_len = *rec_len;
        self.unrecorded = *unrecorded;
        self.phase = *phase;
        // A new epoch, never the old one: an update prepared for the
        // estimator this slot held is refused as stale.
        self.epoch = self.epoch.wrapping_add(1);
        self.candidate = *candidate;
        self.adapted = *adapted;
        self.min_adapted = *min_adapted;
        self.countdown = *countdown;
        self.frozen = *frozen;
        self.initial = *initial;
        self.updates = *updates;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{filter, Rig, Small, SmallCompact};
    use super::*;
    use crate::estimator::Estimator;

    /// A used estimator rebuilt with other settings steps exactly like a
    /// new one with those settings.
    #[test]
    fn rebuilt_in_place_steps_like_new() {
        let mut used = Small::<f64>::new(&filter(), &RobustConfig::default()).unwrap();
        let mut rig = Rig::new();
        rig.run(&mut used, 0.5);
        let other = FilterConfig {
            lambda_rad_s: 150.0,
            ..filter()
        };
        let cfg = RobustConfig {
            forgetting: 0.02,
            update_every: 500,
            ..RobustConfig::default()
        };
        used.rebuild(&other, &cfg).unwrap();
        let mut fresh = Small::<f64>::new(&other, &cfg).unwrap();
        let mut rig = Rig::new();
        for _ in 0..6_000 {
            let (u, y) = rig.sample();
            assert_eq!(used.step(u, y), fresh.step(u, y));
        }
        assert_eq!(used.phase(), fresh.phase());
        assert_ne!(used.phase(), super::super::Phase::Startup);
        assert_eq!(used.updates(), fresh.updates());
        assert_eq!(used.theta(), fresh.theta());
        assert_eq!(used.information(), fresh.information());
    }

    /// Written into place, it steps like one built by value.
    #[test]
    fn new_in_steps_like_new() {
        let mut slot = core::mem::MaybeUninit::uninit();
        let placed = Small::<f64>::new_in(&mut slot, &filter(), &RobustConfig::default()).unwrap();
        let mut fresh = Small::<f64>::new(&filter(), &RobustConfig::default()).unwrap();
        let mut rig = Rig::new();
        for _ in 0..6_000 {
            let (u, y) = rig.sample();
            assert_eq!(placed.step(u, y), fresh.step(u, y));
        }
        assert_eq!(placed.theta(), fresh.theta());
        assert_eq!(Small::information(placed), Small::information(&fresh));
    }

    /// Invalid settings leave the estimator as it was.
    #[test]
    fn refused_rebuild_changes_nothing() {
        let mut est = Small::<f64>::new(&filter(), &RobustConfig::default()).unwrap();
        Rig::new().run(&mut est, 0.3);
        let before = (est.theta(), est.recorded(), est.phase(), est.updates());
        let bad = RobustConfig {
            forgetting: -1.0,
            ..RobustConfig::default()
        };
        assert!(est.rebuild(&filter(), &bad).is_err());
        assert_eq!(
            before,
            (est.theta(), est.recorded(), est.phase(), est.updates())
        );
    }

    /// A compact record's estimator: written into place it steps like one
    /// built by value; a used one given a head built elsewhere
    /// ([`RobustEstimator::install`]) steps like a new one.
    #[test]
    fn compact_estimators_in_place_and_installed_heads_step_like_new() {
        let cfg = RobustConfig {
            update_every: 500,
            ..RobustConfig::default()
        };
        let mut slot = core::mem::MaybeUninit::uninit();
        let placed = SmallCompact::<f32>::new_in(&mut slot, &filter(), &cfg).unwrap();
        let mut rig = Rig::new();
        rig.run(placed, 0.5);
        let other = FilterConfig {
            lambda_rad_s: 150.0,
            ..filter()
        };
        let head = Head::<f32, 4, 7, 28>::new(&other, &cfg).unwrap();
        placed.install(&head);
        let mut fresh = SmallCompact::<f32>::new(&other, &cfg).unwrap();
        let mut rig = Rig::new();
        for _ in 0..6_000 {
            let (u, y) = rig.sample();
            assert_eq!(
                placed.step(u as f32, y as f32),
                fresh.step(u as f32, y as f32)
            );
        }
        assert_eq!(placed.phase(), fresh.phase());
        assert_eq!(placed.updates(), fresh.updates());
        assert!(fresh.updates() > 0);
        assert_eq!(placed.theta(), fresh.theta());
    }
}
