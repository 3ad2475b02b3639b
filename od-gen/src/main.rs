//! `od-gen`: see [`od_gen::cli`] for the commands.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Err(e) = od_gen::cli::run(&args) {
        eprintln!("od-gen: {e}");
        std::process::exit(1);
    }
}
