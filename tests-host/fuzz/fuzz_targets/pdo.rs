//! libFuzzer entry of the `pdo` target (`fuzz_targets::targets::pdo`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::pdo::run(data) {
        panic!("oracle: {}", v.0);
    }
});
