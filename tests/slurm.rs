//! A real scheduler: a single-node Slurm (Debian's `slurm-wlm` and `munge`, which
//! `cargo xtask setup` installs) that this test starts in a scratch folder runs the Slurm
//! script of docs/farm as a 4-task array over 8 probes. One task is requeued in the middle of
//! its bake (Slurm cancels it, as preemption or a node failure would); the documented merge
//! job then finds the set complete, and every file is byte-identical to one unsharded run.
//!
//! Outside CI a machine without Slurm, munge or root skips the test (noted in the summary); in
//! CI each of those fails it.

mod common;

use common::bake::temp;
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::Mapping;
use envlight::EnvMap;
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The bake's sizes (as tests/cli_bake.rs's): small, so that 8 probes bake in seconds on
/// lavapipe.
const SMALL: &str =
    "--specular-size 16 --specular-levels 4 --irradiance-size 8 --samples 16 --device cpu";

/// The daemons a single-node cluster needs, each in the foreground as this test's child.
const DAEMONS: [&str; 3] = ["munged", "slurmctld", "slurmd"];
/// The clients the test drives it with.
const CLIENTS: [&str; 5] = ["sbatch", "scontrol", "squeue", "sinfo", "scancel"];

/// Where `name` is on PATH or in the system folders Debian installs daemons to.
fn which(name: &str) -> Option<PathBuf> {
    let path = std::env::var("PATH").unwrap_or_default();
    let found = path
        .split(':')
        .chain(["/usr/sbin", "/sbin", "/usr/bin"])
        .map(|d| Path::new(d).join(name))
        .find(|p| p.is_file());
    found
}

/// The programs, or why the test cannot run here (a failure in CI, a noted skip elsewhere).
fn programs() -> Option<Vec<PathBuf>> {
    let found: Vec<Option<PathBuf>> = DAEMONS.iter().chain(&CLIENTS).map(|n| which(n)).collect();
    let missing: Vec<&str> = DAEMONS
        .iter()
        .chain(&CLIENTS)
        .zip(&found)
        .filter(|(_, p)| p.is_none())
        .map(|(n, _)| *n)
        .collect();
    let uid = Command::new("id").arg("-u").output().unwrap();
    let root = String::from_utf8_lossy(&uid.stdout).trim() == "0";
    let why = if !missing.is_empty() {
        format!("{missing:?} not installed (cargo xtask setup installs slurm-wlm and munge)")
    } else if !root {
        "slurmd must run as root to start jobs".to_string()
    } else {
        return Some(found.into_iter().flatten().collect());
    };
    assert!(
        std::env::var_os("CI").is_none(),
        "the Slurm test must run in CI: {why}"
    );
    common::skipped(&why);
    None
}

/// A free TCP port on loopback (bound, then released for the daemon).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A single-node cluster in a scratch folder: munged, slurmctld and slurmd on free ports, all
/// stopped (and their jobs cancelled) when it drops.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl Cluster {
    fn start(dir: PathBuf) -> Cluster {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        let key = dir.join("munge.key");
        let mut bytes = vec![0u8; 1024];
        use std::io::Read;
        std::fs::File::open("/dev/urandom")
            .unwrap()
            .read_exact(&mut bytes)
            .unwrap();
        std::fs::write(&key, bytes).unwrap();
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600)).unwrap();
        // The node as slurmd sees it (name, CPUs, sockets), without its memory, which drifts.
        let probe = Command::new("slurmd").arg("-C").output().unwrap();
        let node = String::from_utf8_lossy(&probe.stdout)
            .lines()
            .next()
            .expect("slurmd -C prints the node")
            .split_whitespace()
            .filter(|w| !w.starts_with("RealMemory"))
            .collect::<Vec<_>>()
            .join(" ");
        let host = node
            .strip_prefix("NodeName=")
            .and_then(|s| s.split_whitespace().next())
            .unwrap()
            .to_string();
        let conf = dir.join("slurm.conf");
        std::fs::write(&conf, slurm_conf(&dir, &host, &node)).unwrap();
        for sub in ["state", "spool"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let mut cluster = Cluster {
            dir: dir.clone(),
            conf: conf.clone(),
            daemons: Vec::new(),
        };
        let d = |s: &str| dir.join(s).display().to_string();
        cluster.spawn(
            "munged",
            &[
                "-F",
                "--force",
                &format!("--socket={}", d("munge.sock")),
                &format!("--key-file={}", d("munge.key")),
                &format!("--log-file={}", d("munged.log")),
                &format!("--pid-file={}", d("munged.pid")),
                &format!("--seed-file={}", d("munged.seed")),
            ],
        );
        wait_for("munged's socket", 20, || dir.join("munge.sock").exists());
        let conf = conf.display().to_string();
        cluster.spawn("slurmctld", &["-D", "-i", "-f", &conf]);
        cluster.spawn("slurmd", &["-D", "-f", &conf]);
        wait_for("the node to be idle", 60, || {
            let o = cluster.client("sinfo", &["-h", "-o", "%t"]);
            String::from_utf8_lossy(&o.stdout).trim() == "idle"
        });
        cluster
    }

    fn spawn(&mut self, program: &str, args: &[&str]) {
        let log = std::fs::File::create(self.dir.join(format!("{program}.out"))).unwrap();
        let child = Command::new(which(program).unwrap())
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {program}: {e}"));
        self.daemons.push(child);
    }

    /// A client command against this cluster, with no Slurm variables of an enclosing job.
    fn client(&self, program: &str, args: &[&str]) -> Output {
        let mut c = Command::new(which(program).unwrap());
        for (k, _) in std::env::vars_os() {
            if k.to_string_lossy().starts_with("SLURM_") {
                c.env_remove(k);
            }
        }
        c.args(args).env("SLURM_CONF", &self.conf).output().unwrap()
    }

    /// `scontrol show job J` as one line per job (an array's tasks each on theirs).
    fn jobs(&self, job: &str) -> Vec<String> {
        let o = self.client("scontrol", &["-o", "show", "job", job]);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(str::to_string)
            .collect()
    }

    /// What the daemons logged, for a failure's message.
    fn logs(&self) -> String {
        ["slurmctld.out", "slurmd.out", "munged.out"]
            .iter()
            .map(|f| {
                let t = std::fs::read_to_string(self.dir.join(f)).unwrap_or_default();
                let tail: Vec<&str> = t.lines().rev().take(15).collect();
                format!(
                    "== {f}\n{}",
                    tail.into_iter().rev().collect::<Vec<_>>().join("\n")
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = self.client("scancel", &["--user=root"]);
        for d in self.daemons.iter_mut().rev() {
            let _ = d.kill();
            let _ = d.wait();
        }
        // The daemons' logs stay for a failed test to be read.
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// slurm.conf for one node that is also the controller, everything in `dir`, authenticated by
/// this test's munged. No cgroups (a container may not delegate them) and no accounting.
fn slurm_conf(dir: &Path, host: &str, node: &str) -> String {
    let d = dir.display();
    format!(
        "ClusterName=envlight-test\n\
         SlurmctldHost={host}(127.0.0.1)\n\
         SlurmctldPort={}\n\
         SlurmdPort={}\n\
         AuthType=auth/munge\n\
         CredType=cred/munge\n\
         AuthInfo=socket={d}/munge.sock\n\
         SlurmUser=root\n\
         SlurmdUser=root\n\
         StateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\n\
         SlurmctldPidFile={d}/slurmctld.pid\n\
         SlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/slurmctld.log\n\
         SlurmdLogFile={d}/slurmd.log\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         JobAcctGatherType=jobacct_gather/none\n\
         AccountingStorageType=accounting_storage/none\n\
         MpiDefault=none\n\
         SwitchType=switch/none\n\
         SchedulerType=sched/backfill\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_CPU\n\
         ReturnToService=2\n\
         {node} NodeAddr=127.0.0.1 State=UNKNOWN\n\
         PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
        free_port(),
        free_port(),
    )
}

/// Polls `done` every 50 ms for up to `secs` seconds; panics naming `what` if it never holds.
fn wait_for(what: &str, secs: u64, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(
            start.elapsed() < Duration::from_secs(secs),
            "waited {secs} s for {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Eight probes; the sixth (p5, the second of task 1's shard: shards take every fourth
/// probe) is 4096×2048, a large probe (over 4 Mi texels: read, reduced to the light records'
/// grid and uploaded in bands), so that its bake lasts long enough to be interrupted.
fn eight_probes(dir: &Path) {
    for k in 0..8u32 {
        let angle = f64::from(k) * 0.7;
        let sky = Sky {
            sun_dir: DVec3::new(angle.cos() * 0.8, 0.6, angle.sin() * 0.8),
            ..Sky::default()
        };
        let (w, h) = if k == 5 {
            (4096, 2048)
        } else {
            (64 + 16 * k, 32 + 8 * k)
        };
        let map = if k % 2 == 0 {
            EnvMap::from_fn(Mapping::LatLong, w, h, 2, move |d| sky.radiance(d))
        } else {
            EnvMap::from_fn(Mapping::LatLong, w, h, 2, move |d| {
                let s = smooth_env(d);
                [
                    s[(k as usize) % 3],
                    s[(k as usize + 1) % 3],
                    s[(k as usize + 2) % 3],
                ]
            })
        };
        envlight::io::save_exr(&map, dir.join(format!("p{k}.exr"))).unwrap();
    }
}

/// The one field `key` of a `scontrol -o show job` line.
fn field<'a>(line: &'a str, key: &str) -> &'a str {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key).and_then(|v| v.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key} in {line}"))
}

#[test]
fn a_slurm_array_requeued_mid_bake_merges_to_one_runs_files() {
    let Some(_) = programs() else { return };
    let inputs = temp("slurm-in");
    eight_probes(&inputs);
    let bin = Path::new(env!("CARGO_BIN_EXE_envlight"));

    // One unsharded run: what the farm must reproduce byte for byte.
    let single = temp("slurm-single");
    let o = Command::new(bin)
        .args([
            "bake",
            inputs.to_str().unwrap(),
            "-o",
            single.to_str().unwrap(),
        ])
        .args(SMALL.split(' '))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let cluster = Cluster::start(temp("slurm-cluster"));
    let out = temp("slurm-out");
    let logs = temp("slurm-logs");
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/farm/slurm.sbatch");
    // The script as documented; this node has no GPU to give (--gres=none) and 4 tasks, not
    // the script's 8. The environment reaches the tasks (sbatch exports it by default).
    let submit = |args: &[&str]| {
        let mut c = Command::new(which("sbatch").unwrap());
        c.args(["--parsable", "--gres=none", "--chdir"])
            .arg(&logs)
            .args(args)
            .env("SLURM_CONF", &cluster.conf)
            .env("PATH", &path)
            .env("PROBES", &inputs)
            .env("OUT", &out)
            .env("ENVLIGHT_BAKE_FLAGS", SMALL);
        let o = c.output().unwrap();
        assert!(
            o.status.success(),
            "sbatch: {}\n{}",
            String::from_utf8_lossy(&o.stderr),
            cluster.logs()
        );
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    let job = submit(&[
        "--array=0-3",
        "--open-mode=append",
        "--output=task-%a.log",
        script.to_str().unwrap(),
    ]);

    // Task 1 bakes p1, then p5: requeue it once p1 is done and p5 is not.
    wait_for("task 1 to finish p1", 300, || {
        out.join("p1.exr/probe.json").exists()
    });
    assert!(
        !out.join("p5.exr/probe.json").exists(),
        "task 1 finished p5 before the test could interrupt it"
    );
    let task = format!("{job}_1");
    let o = cluster.client("scontrol", &["requeue", &task]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A requeued job waits (Slurm's default: two minutes) before it may start again; a
    // scheduler's operator, or this test, lets it start now.
    wait_for("the requeued task to be pending", 60, || {
        cluster
            .jobs(&task)
            .first()
            .is_some_and(|l| field(l, "JobState") == "PENDING")
    });
    let o = cluster.client(
        "scontrol",
        &["update", &format!("jobid={task}"), "StartTime=now"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // The merge as the script's header gives it: after every task has ended.
    let merge = submit(&[
        &format!("--dependency=afterany:{job}"),
        "--output=merge.log",
        "--wrap",
        &format!("envlight bake --merge -o {}", out.display()),
    ]);
    wait_for("the array and the merge to end", 600, || {
        let o = cluster.client("squeue", &["-h", "-j", &format!("{job},{merge}")]);
        o.status.success() && String::from_utf8_lossy(&o.stdout).trim().is_empty()
    });
    check_jobs(&cluster, &job, &merge, &logs, &out);
    check_outputs(&single, &out);
    for d in [&inputs, &single, &out, &logs] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Every task and the merge completed with exit code 0; task 1 ran twice, and its second run
/// skipped the p1 its first had finished and baked p5.
fn check_jobs(cluster: &Cluster, job: &str, merge: &str, logs: &Path, out: &Path) {
    let lines = cluster.jobs(job);
    assert_eq!(lines.len(), 4, "{lines:?}");
    for l in lines.iter().chain(&cluster.jobs(merge)) {
        let log = std::fs::read_to_string(logs.join(format!(
            "task-{}.log",
            l.split_whitespace()
                .find_map(|w| w.strip_prefix("ArrayTaskId="))
                .unwrap_or("merge")
        )))
        .unwrap_or_default();
        assert_eq!(field(l, "JobState"), "COMPLETED", "{l}\n{log}");
        assert_eq!(field(l, "ExitCode"), "0:0", "{l}\n{log}");
    }
    let restarts: Vec<(&str, &str)> = lines
        .iter()
        .map(|l| (field(l, "ArrayTaskId"), field(l, "Restarts")))
        .collect();
    for (task, n) in &restarts {
        assert_eq!(*n, if *task == "1" { "1" } else { "0" }, "{restarts:?}");
    }
    let task1 = std::fs::read_to_string(logs.join("task-1.log")).unwrap();
    assert!(task1.contains("DUE TO JOB REQUEUE"), "{task1}");
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest-shard-2-of-4.json")).unwrap())
            .unwrap();
    let status = |name: &str| {
        manifest["probes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["input"].as_str().unwrap().ends_with(name))
            .map(|e| e["status"].as_str().unwrap().to_string())
    };
    assert_eq!(status("p1.exr").as_deref(), Some("skipped"), "{manifest}");
    assert_eq!(status("p5.exr").as_deref(), Some("baked"), "{manifest}");
}

/// The merged manifest lists the 8 probes, none failed, with the single run's output hashes;
/// every file a probe's folder holds, but its record of this run (`probe.json`: times, paths)
/// and its lock, is byte-identical to the single run's (previews included); the gallery has a
/// card a probe.
fn check_outputs(single: &Path, out: &Path) {
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p.join("manifest.json")).unwrap()).unwrap()
    };
    let outputs = |m: &serde_json::Value| {
        let mut v: Vec<(String, String, serde_json::Value)> = m["probes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| {
                let name = e["input"].as_str().unwrap().rsplit('/').next().unwrap();
                (
                    name.to_string(),
                    e["status"].as_str().unwrap().to_string(),
                    e["outputs"].clone(),
                )
            })
            .collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    };
    let (a, b) = (outputs(&read(single)), outputs(&read(out)));
    assert_eq!(b.len(), 8, "{b:?}");
    for ((na, _, oa), (nb, sb, ob)) in a.iter().zip(&b) {
        assert_eq!(na, nb);
        assert!(sb == "baked" || sb == "skipped", "{nb}: {sb}");
        assert_eq!(oa, ob, "{nb}: the manifests' outputs differ");
    }
    let mut compared = 0;
    for (name, _, _) in &a {
        for f in std::fs::read_dir(single.join(name)).unwrap().flatten() {
            let file = f.file_name().to_string_lossy().to_string();
            if file == "probe.json" || file == ".lock" {
                continue;
            }
            let x = std::fs::read(f.path()).unwrap();
            let y = std::fs::read(out.join(name).join(&file))
                .unwrap_or_else(|e| panic!("{name}/{file}: {e}"));
            assert!(x == y, "{name}/{file} differs from the single run's");
            compared += 1;
        }
    }
    assert_eq!(
        compared,
        8 * 4,
        "sh.json, irradiance.ktx2, specular.ktx2 and preview.png per probe"
    );
    // The merge's gallery: one card a probe, whichever shard baked it.
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert_eq!(page.matches("<article class=\"card").count(), 8);
}
