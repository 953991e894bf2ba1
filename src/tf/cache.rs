//! One frame's transforms to its parent: a static one (kept until replaced) or a time-sorted
//! cache of dynamic ones, pruned to the buffer's cache time, as tf2's `StaticCache` and
//! `TimeCache` (`tf2/src/static_cache.cpp`, `tf2/src/cache.cpp`).

use super::error::Extrapolation;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::collections::VecDeque;

/// One transform of a frame: where it is in its parent at `stamp`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    /// ns since the epoch (0 for a static transform).
    pub(crate) stamp: i64,
    /// The parent frame's index.
    pub(crate) parent: u32,
    /// The frame's origin in the parent, m.
    pub(crate) translation: Vector3<f64>,
    /// The frame's orientation in the parent.
    pub(crate) rotation: UnitQuaternion<f64>,
}

/// A frame's transforms to its parent.
#[derive(Debug, Clone)]
pub(crate) enum Cache {
    /// From `/tf_static`: one transform, valid at every time.
    Static(Sample),
    /// From `/tf`: oldest first, stamps distinct, at least one.
    Dynamic(VecDeque<Sample>),
}

/// What inserting a sample did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Inserted {
    /// A new sample: the cache holds one more.
    Added,
    /// It took the place of the sample at the same stamp (or of the static transform).
    Replaced,
    /// Older than the cache time before the latest sample: dropped, as tf2's `TF_OLD_DATA`.
    TooOld,
}

impl Cache {
    /// How many samples the cache holds.
    pub(crate) fn len(&self) -> usize {
        match self {
            Cache::Static(_) => 1,
            Cache::Dynamic(samples) => samples.len(),
        }
    }

    /// The latest sample's stamp (0 for a static transform, which holds at every time) and its
    /// parent, as tf2's `getLatestTimeAndParent`.
    pub(crate) fn latest(&self) -> (i64, u32) {
        match self {
            Cache::Static(s) => (0, s.parent),
            Cache::Dynamic(samples) => samples.back().map_or((0, 0), |s| (s.stamp, s.parent)),
        }
    }

    /// Makes room for a new dynamic sample at `stamp` by dropping the oldest one; the only one
    /// goes only for a newer sample, so that the frame keeps its latest. False when neither.
    pub(crate) fn make_room(&mut self, stamp: i64) -> bool {
        match self {
            Cache::Dynamic(samples)
                if samples.len() > 1 || samples.front().is_some_and(|s| s.stamp < stamp) =>
            {
                samples.pop_front().is_some()
            }
            _ => false,
        }
    }

    /// What [`Cache::insert`] would do with a sample at `stamp`, changing nothing.
    pub(crate) fn plan(&self, stamp: i64, cache_time: i64) -> Inserted {
        let Cache::Dynamic(samples) = self else {
            return Inserted::Replaced;
        };
        let latest = samples.back().map_or(i64::MIN, |s| s.stamp);
        if stamp < latest.saturating_sub(cache_time) {
            return Inserted::TooOld;
        }
        let at = samples.partition_point(|s| s.stamp < stamp);
        match samples.get(at) {
            Some(there) if there.stamp == stamp => Inserted::Replaced,
            _ => Inserted::Added,
        }
    }

    /// Puts a dynamic `sample` in its place by stamp and prunes the samples older than
    /// `cache_time` ns before the latest (keeping at least one), as tf2's
    /// `TimeCache::insertData`; a static transform becomes this one sample. As tf2, a sample
    /// older than that window is refused; unlike tf2, which keeps both, a sample at a stamp
    /// already held replaces the one there, so that a repeated stamp cannot grow the cache.
    pub(crate) fn insert(&mut self, sample: Sample, cache_time: i64) -> Inserted {
        let plan = self.plan(sample.stamp, cache_time);
        let Cache::Dynamic(samples) = self else {
            *self = Cache::Dynamic(VecDeque::from([sample]));
            return plan;
        };
        let at = samples.partition_point(|s| s.stamp < sample.stamp);
        match plan {
            Inserted::TooOld => return plan,
            Inserted::Replaced => samples[at] = sample,
            Inserted::Added => samples.insert(at, sample),
        }
        let newest = samples.back().map_or(sample.stamp, |s| s.stamp);
        while samples.len() > 1
            && samples
                .front()
                .is_some_and(|s| s.stamp < newest.saturating_sub(cache_time))
        {
            samples.pop_front();
        }
        plan
    }

    /// The transform at `time` (0: the latest), as tf2's `TimeCache::getData`: a sample at
    /// that stamp, or the two around it interpolated (translation linearly, rotation by slerp);
    /// across a change of parent, the older sample. No extrapolation either way.
    pub(crate) fn at(&self, time: i64) -> Result<Sample, Extrapolation> {
        let samples = match self {
            Cache::Static(s) => return Ok(Sample { stamp: time, ..*s }),
            Cache::Dynamic(samples) => samples,
        };
        let (Some(first), Some(last)) = (samples.front(), samples.back()) else {
            // Never empty; an empty cache reads as the one sample being elsewhere.
            return Err(Extrapolation::Single {
                requested: time,
                only: 0,
            });
        };
        if time == 0 {
            return Ok(*last);
        }
        if samples.len() == 1 {
            return if first.stamp == time {
                Ok(*first)
            } else {
                Err(Extrapolation::Single {
                    requested: time,
                    only: first.stamp,
                })
            };
        }
        if time > last.stamp {
            return Err(Extrapolation::Future {
                requested: time,
                latest: last.stamp,
            });
        }
        if time < first.stamp {
            return Err(Extrapolation::Past {
                requested: time,
                earliest: first.stamp,
            });
        }
        // The first sample at or after `time`; its predecessor is before it.
        let after = samples.partition_point(|s| s.stamp < time);
        let newer = samples[after];
        if newer.stamp == time || after == 0 {
            return Ok(newer);
        }
        let older = samples[after - 1];
        if older.parent != newer.parent {
            return Ok(Sample {
                stamp: time,
                ..older
            });
        }
        let ratio = (time - older.stamp) as f64 / (newer.stamp - older.stamp) as f64;
        Ok(Sample {
            stamp: time,
            parent: older.parent,
            translation: older.translation.lerp(&newer.translation, ratio),
            rotation: slerp(&older.rotation, &newer.rotation, ratio),
        })
    }
}

/// Spherical linear interpolation from `a` (t = 0) to `b` (t = 1) along the shorter arc, as
/// tf2's `Quaternion::slerp`.
///
/// With `b` negated where `a·b < 0` (the same rotation, the nearer of its two quaternions),
/// the angle between the two unit 4-vectors is `θ = acos(a·b)` in [0, π/2], and
/// `q(t) = (sin((1−t)θ) a + sin(tθ) b) / sin θ` keeps unit length and turns at a constant rate.
/// Where θ is tiny the quotient loses its digits; there `q(t)` is, to O(θ²), the normalised
/// linear blend `(1−t) a + t b`.
pub(crate) fn slerp(
    a: &UnitQuaternion<f64>,
    b: &UnitQuaternion<f64>,
    t: f64,
) -> UnitQuaternion<f64> {
    let a = a.as_ref().coords;
    let mut b = b.as_ref().coords;
    let mut dot = a.dot(&b);
    if dot < 0.0 {
        b = -b;
        dot = -dot;
    }
    let blend = if dot > 1.0 - 1e-12 {
        a * (1.0 - t) + b * t
    } else {
        let theta = dot.min(1.0).acos();
        let s = theta.sin();
        a * (((1.0 - t) * theta).sin() / s) + b * ((t * theta).sin() / s)
    };
    UnitQuaternion::from_quaternion(Quaternion::from(blend))
}
