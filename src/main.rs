//! The `daystep` binary: a thin shell over [`daystep::cli`].

fn main() {
    std::process::exit(daystep::cli::main());
}
