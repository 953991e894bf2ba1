//! The files `recover -o` and `replay --write` write get the mode the umask gives.

use std::path::Path;

const NODE_BAG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/node_recorded.mcap");

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8")
}

/// The mode of the file a command run under `umask` writes to `output`.
fn mode_written(umask: &str, command: &str, output: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    let script = format!("umask {umask} && exec \"$0\" {command} \"$1\"");
    let out = std::process::Command::new("sh")
        .args(["-c", &script, env!("CARGO_BIN_EXE_grasp_orient"), s(output)])
        .output()
        .expect("runs");
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{command}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::metadata(output)
        .expect("written")
        .permissions()
        .mode()
        & 0o777
}

/// The outputs of `recover -o` and `replay --write` get 0666 less the umask, like any file a
/// command creates (they are written under a temporary name and renamed).
#[test]
fn outputs_get_the_mode_the_umask_gives() {
    let dir = temp_dir("modes");
    for (umask, mode) in [("022", 0o644), ("027", 0o640), ("002", 0o664)] {
        for (command, name) in [
            (format!("recover {NODE_BAG} -o"), "recovered.mcap"),
            (format!("replay {NODE_BAG} --write"), "replayed.mcap"),
        ] {
            let output = dir.path().join(format!("{umask}-{name}"));
            assert_eq!(
                mode_written(umask, &command, &output),
                mode,
                "{command} under umask {umask}"
            );
        }
    }
}
