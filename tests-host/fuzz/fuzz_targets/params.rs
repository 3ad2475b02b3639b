//! libFuzzer entry of the `params` target (`fuzz_targets::targets::params`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::params::run(data) {
        panic!("oracle: {}", v.0);
    }
});
