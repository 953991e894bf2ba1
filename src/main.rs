//! `grasp_orient`: the command line and the ROS 2 node (`grasp_orient::run`).

/// mimalloc, not the system allocator: a set's answers are kept until it is published, and
/// glibc's allocator made keeping them cost more than solving them (`cargo bench --bench sets`).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    grasp_orient::run()
}
