//! `solver-service`: placeholder entry point until the service lands (issue 3).

fn main() {
    eprintln!(
        "solver-service: the iceoryx2 service is not built yet; the kernel is in the `solver` library"
    );
    std::process::exit(1);
}
