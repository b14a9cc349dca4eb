//! The vector instructions this build was compiled for, and whether the running CPU has them.
//!
//! On x86-64 the workspace is built with AVX and AVX2 (`.cargo/config.toml`): the likelihood's
//! per-bin products and the Gram sums then run on 256-bit vectors of four doubles instead of
//! 128-bit ones of two. The numbers do not depend on it (no fused multiply-add is enabled,
//! every sum keeps its order), only the speed: a sweep of paper case 1 ran at 105 trials/s
//! without and 127 with (criterion, two threads). A binary built so stops with illegal
//! instructions on a CPU without them (x86-64 CPUs before 2013-2015), so the front ends
//! (the `frameid` binary, the Python module) call [`missing_features`] first and refuse to
//! run with a message. Such a machine builds without them by setting `RUSTFLAGS` (which
//! replaces the configured flags), e.g. `RUSTFLAGS="-C target-cpu=native" cargo build
//! --release`.

/// The instruction-set extensions the build uses that the running CPU lacks (empty when it
/// can run this build).
pub fn missing_features() -> Vec<&'static str> {
    #[allow(unused_mut)]
    let mut missing = Vec::new();
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    if !std::arch::is_x86_feature_detected!("avx") {
        missing.push("avx");
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    if !std::arch::is_x86_feature_detected!("avx2") {
        missing.push("avx2");
    }
    missing
}

/// The message of a front end that refuses to run on a CPU without [`missing_features`], or
/// `None` if the CPU has them.
pub fn unsupported_message() -> Option<String> {
    let missing = missing_features();
    (!missing.is_empty()).then(|| {
        format!(
            "this build of frameid uses CPU instructions this processor lacks ({}); \
             rebuild it for this machine with RUSTFLAGS=\"-C target-cpu=native\" \
             (see the README, \"Building\")",
            missing.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    /// The machine that builds and tests is the one that runs: it has what the build uses.
    #[test]
    fn the_test_machine_has_the_build_s_instructions() {
        assert_eq!(super::missing_features(), Vec::<&str>::new());
        assert!(super::unsupported_message().is_none());
    }
}
