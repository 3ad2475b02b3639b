//! libFuzzer entry of the `esm` target (`fuzz_targets::targets::esm`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::esm::run(data) {
        panic!("oracle: {}", v.0);
    }
});
