//! `od-gen`: see [`od_gen::cli`] for the commands.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Err(e) = od_gen::cli::run(&args) {
        match e {
            // Every error of a profile, one per line.
            od_gen::cli::CliError::Od(e) => {
                for one in e.errors() {
                    eprintln!("od-gen: {one}");
                }
            }
            usage => eprintln!("od-gen: {usage}"),
        }
        std::process::exit(1);
    }
}
