//! libFuzzer entry of the `profile` target (`fuzz_targets::targets::profile`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::profile::run(data) {
        panic!("oracle: {}", v.0);
    }
});
