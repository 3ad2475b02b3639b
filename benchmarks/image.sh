# Sourced by benchmarks/run and benchmarks/profile: builds the benchmark image of boards/qemu-m4
# (release) the one way both measure it, and sets `elf` (its path) and `runner` (the QEMU
# command line of boards/qemu-m4/.cargo/config.toml). Needs `root` (the checkout).
bench_crate="$root/boards/qemu-m4"
bench_target=thumbv7em-none-eabihf
# The source paths compiled into the image (panic locations) are remapped, so that its layout,
# and with it the branches and loads the cycle model sees, does not depend on where the
# checkout is (an absolute path in a different place shifts the read-only data).
(cd "$bench_crate" && cargo build --release \
    --config "target.$bench_target.rustflags = [\"--remap-path-prefix=$root=/checkout\"]")
runner="$(sed -n 's/^runner = "\(.*\)"$/\1/p' "$bench_crate/.cargo/config.toml")"
elf="$bench_crate/target/$bench_target/release/bench-qemu-m4"
