//! libFuzzer entry of the `mailbox` target (`fuzz_targets::targets::mailbox`): a violation of its
//! oracle is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(v) = fuzz_targets::targets::mailbox::run(data) {
        panic!("oracle: {}", v.0);
    }
});
