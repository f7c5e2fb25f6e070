//! Code that other crates want compiled for wider vector units, entered only on CPUs that
//! have them: the one place outside the traversal kernels where lamina chooses
//! instructions at run time (the renderer's wavefront path tracer runs its per-lane
//! arithmetic through [`run_wide`]). The crates that use it stay free of `unsafe`.
//!
//! How it works: [`run_wide`] calls the task from a function compiled with AVX2, FMA and
//! BMI1/2 enabled, after checking that this CPU has them; the task's
//! [`WideTask::run`], marked `#[inline(always)]`, is inlined there, so its loops are
//! vectorized for those units. Enabling FMA lets the compiler *use* fused instructions for
//! explicit `mul_add` calls only: Rust never contracts `a * b + c`, so the task's results
//! are bit for bit those of the plain build.

/// Work to run through [`run_wide`]. Implementations mark [`WideTask::run`]
/// `#[inline(always)]`, or it is compiled for the plain target after all.
pub trait WideTask {
    /// What the work returns.
    type Output;
    /// Does the work.
    fn run(self) -> Self::Output;
}

/// Whether [`run_wide`] runs tasks with AVX2 + FMA + BMI1/2 code on this CPU.
pub fn wide_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("bmi2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Runs `task`, compiled for AVX2 + FMA + BMI1/2 where [`wide_available`] (the same
/// results: module docs), for the plain target elsewhere.
#[inline]
pub fn run_wide<T: WideTask>(task: T) -> T::Output {
    #[cfg(target_arch = "x86_64")]
    if wide_available() {
        #[target_feature(enable = "avx2,fma,bmi1,bmi2")]
        fn wide<T: WideTask>(task: T) -> T::Output {
            task.run()
        }
        // SAFETY: `wide` only enables AVX2, FMA, BMI1 and BMI2, and `wide_available` has
        // just confirmed that this CPU has all four.
        return unsafe { wide(task) };
    }
    task.run()
}

/// Asks the CPU to bring `value`'s cache lines in ahead of a read (a hint: nothing
/// happens where the CPU has no such instruction).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    crate::traverse::prefetch_lines(value as *const T as *const u8, std::mem::size_of::<T>());
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Sum<'a>(&'a [f32]);

    impl WideTask for Sum<'_> {
        type Output = f32;
        #[inline(always)]
        fn run(self) -> f32 {
            self.0.iter().fold(0.0, |a, &x| a + x * 0.5)
        }
    }

    #[test]
    fn wide_and_plain_agree_bit_for_bit() {
        let v: Vec<f32> = (0..1000).map(|i| (i as f32 * 0.37).sin() * 1e3).collect();
        let plain = Sum(&v).run();
        assert_eq!(run_wide(Sum(&v)).to_bits(), plain.to_bits());
    }
}
