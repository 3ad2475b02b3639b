//! libFuzzer entry of the `frames` target (`fuzz_targets::targets::frames`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::frames::run(data) {
        panic!("oracle: {}", v.0);
    }
});
