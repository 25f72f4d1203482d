"""A real single-node SLURM on this machine, for the cluster tests and benchmarks/bench_slurm.py.

:func:`start` installs Debian's ``munge``, ``slurmctld``, ``slurmd`` and ``slurm-client`` if they
are missing (``apt-get --no-install-recommends``; needs root, as in CI), writes a ``slurm.conf``
in a folder of its own (this machine as the one node ``localhost``, with the CPUs and memory
``slurmd -C`` reports, no accounting database, free ports), starts ``munged`` (unless one already
answers), ``slurmctld`` and ``slurmd`` without systemd and waits until ``sinfo`` shows the node
idle. :meth:`LocalSlurm.stop` shuts down what it started, by pid.

The configuration is written to /etc/slurm/slurm.conf, SLURM's default path: the SLURM executor
plugin's job step drops every ``SLURM_*`` variable but the job's identity before it calls
``srun`` inside the job, ``SLURM_CONF`` included, so no other path reaches the job. A file there
that this module did not write is moved aside and put back by :meth:`LocalSlurm.stop`.

When a step fails, :class:`SlurmStartError` carries the daemons' logs, so that a test fails with
them (it never skips).
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

#: Debian packages of a single-node SLURM (22.05 on Debian 12) and the commands each brings.
PACKAGES = {"munge": "munged", "slurmctld": "slurmctld", "slurmd": "slurmd", "slurm-client": "sbatch"}
SBIN = ("/usr/sbin", "/usr/bin")
#: Where SLURM's commands and daemons look for their configuration by default.
SYSTEM_CONF = Path("/etc/slurm/slurm.conf")
#: First line of every slurm.conf this module writes (a stale one is overwritten, others kept).
CONF_HEADER = "# Written by tests/cluster/local_slurm.py: one node (this machine), no accounting database."

#: Seconds a finished job stays visible to squeue. The SLURM executor plugin reads job states
#: with squeue (no accounting database here) and takes a job that has left squeue's view as
#: still running, so this must outlast the plugin's status-check interval (it falls back to
#: sacct below 3x its initial interval).
MIN_JOB_AGE_S = 600
#: Seconds between SIGTERM and SIGKILL when a job is cancelled or hits its time limit.
KILL_WAIT_S = 5
#: Held while a cluster of this module runs: two at once on one machine would share
#: /etc/slurm/slurm.conf and munged (two test sessions on one machine wait for each other).
LOCK_FILE = Path("/run/lock/pidpipe-test-slurm.lock")
LOCK_TIMEOUT_S = 3600

#: How slurmd finds a job's processes to signal them. proctrack/linuxproc follows parent links:
#: the Snakemake that runs a group job ignores SIGTERM (it waits for its jobs), outlives the
#: batch script, is re-parented to init and was never killed (found running 27 min after its
#: job was cancelled). proctrack/pgid signals the job's process group, which it stays in.
#: Sites use proctrack/cgroup, which needs cgroup set-up that a CI machine may not allow.
PROCTRACK = "proctrack/pgid"


class SlurmStartError(RuntimeError):
    """The local SLURM could not be installed or started; the message holds the daemons' logs."""


def _which(command: str) -> str | None:
    return shutil.which(command) or next(
        (f"{d}/{command}" for d in SBIN if os.access(f"{d}/{command}", os.X_OK)), None)


def install_packages() -> None:
    """Install the Debian packages whose commands are missing (apt-get, as root).

    Raises
    ------
    SlurmStartError
        Not root, or apt-get failed (its output is in the message).
    """
    missing = [package for package, command in PACKAGES.items() if _which(command) is None]
    if not missing:
        return
    if os.geteuid() != 0:
        raise SlurmStartError(f"SLURM packages {missing} are missing and this is not root: run "
                              f"apt-get install --no-install-recommends {' '.join(missing)}")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    for command in (["apt-get", "update", "-qq"],
                    ["apt-get", "install", "-y", "-qq", "--no-install-recommends", *missing]):
        run = subprocess.run(command, env=env, text=True, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, timeout=900)
        if run.returncode != 0:
            raise SlurmStartError(f"{' '.join(command)} failed (exit {run.returncode}):\n"
                                  f"{run.stdout[-4000:]}")


def node_hardware() -> dict[str, str]:
    """This machine as ``slurmd -C`` reports it: CPUs, Boards, ..., RealMemory (MB)."""
    run = subprocess.run([_which("slurmd"), "-C"], text=True, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=60)
    if run.returncode != 0:
        raise SlurmStartError(f"slurmd -C failed (exit {run.returncode}):\n{run.stdout}")
    first = run.stdout.splitlines()[0]
    fields = dict(re.findall(r"(\w+)=(\S+)", first))
    keys = ("CPUs", "Boards", "SocketsPerBoard", "CoresPerSocket", "ThreadsPerCore", "RealMemory")
    if not all(key in fields for key in keys):
        raise SlurmStartError(f"slurmd -C did not report {keys}: {first!r}")
    return {key: fields[key] for key in keys}


def _free_ports(count: int) -> list[int]:
    sockets = [socket.socket() for _ in range(count)]
    try:
        for sock in sockets:
            sock.bind(("127.0.0.1", 0))
        return [sock.getsockname()[1] for sock in sockets]
    finally:
        for sock in sockets:
            sock.close()


def slurm_conf(root: Path, hardware: dict[str, str], ports: list[int]) -> str:
    """The text of a single-node ``slurm.conf`` whose state, spool, logs and pids live in ``root``."""
    node = " ".join(f"{key}={value}" for key, value in hardware.items())
    return f"""\
{CONF_HEADER}
ClusterName=pidpipe-test
SlurmctldHost=localhost
SlurmctldPort={ports[0]}
SlurmdPort={ports[1]}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType={PROCTRACK}
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
ReturnToService=2
MinJobAge={MIN_JOB_AGE_S}
KillWait={KILL_WAIT_S}
StateSaveLocation={root}/state
SlurmdSpoolDir={root}/spool
SlurmctldPidFile={root}/slurmctld.pid
SlurmdPidFile={root}/slurmd.pid
SlurmctldLogFile={root}/slurmctld.log
SlurmdLogFile={root}/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=localhost NodeAddr=127.0.0.1 {node} State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
"""


def _munge_works() -> bool:
    munge, unmunge = _which("munge"), _which("unmunge")
    if munge is None or unmunge is None:
        return False
    cred = subprocess.run([munge, "-n"], capture_output=True, timeout=30)
    if cred.returncode != 0:
        return False
    return subprocess.run([unmunge], input=cred.stdout, capture_output=True,
                          timeout=30).returncode == 0


def _wait(predicate, timeout_s: float, interval_s: float = 0.5) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval_s)
    return predicate()


@dataclass
class LocalSlurm:
    """A started single-node SLURM: its folder, ``slurm.conf`` and the daemons this process owns."""

    root: Path
    conf: Path
    cpus: int
    real_memory_mb: int
    processes: dict[str, subprocess.Popen] = field(default_factory=dict)
    munged_pid: int | None = None
    moved_conf: Path | None = None
    lock: object | None = None
    text: str = ""

    def env(self) -> dict[str, str]:
        """Environment variables that point SLURM's commands at this cluster."""
        return {"SLURM_CONF": str(self.conf)}

    def command(self, *args: str, timeout: float = 60) -> subprocess.CompletedProcess:
        """Run a SLURM client command against this cluster; stdout and stderr together."""
        return subprocess.run(list(args), env={**os.environ, **self.env()}, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=timeout)

    def node_state(self) -> str:
        run = self.command("sinfo", "-h", "-N", "-o", "%T")
        return run.stdout.strip() if run.returncode == 0 else f"(sinfo failed: {run.stdout.strip()})"

    def logs(self) -> str:
        """The tail of every daemon's log and captured output, for a failure message."""
        parts = []
        for path in sorted(self.root.glob("*.log")) + sorted(self.root.glob("*.out")):
            text = path.read_text(errors="replace")
            parts.append(f"----- {path} (last 4000 characters) -----\n{text[-4000:]}")
        return "\n".join(parts) or f"(no logs in {self.root})"

    def _start(self, name: str, *args: str) -> None:
        out = open(self.root / f"{name}.out", "w")
        self.processes[name] = subprocess.Popen([_which(name), *args], stdout=out,
                                                stderr=subprocess.STDOUT,
                                                env={**os.environ, **self.env()},
                                                start_new_session=True)
        out.close()

    def stop(self) -> None:
        """Shut down the daemons this object started (``scontrol shutdown``, then by pid).

        ``scontrol`` and the removal of /etc/slurm/slurm.conf only while that file is still the
        one this cluster wrote: another test session's cluster is never touched.
        """
        ours = SYSTEM_CONF.is_file() and SYSTEM_CONF.read_text() == self.text
        if self.processes and ours:
            self.command("scontrol", "shutdown", timeout=30)
        for name, proc in self.processes.items():
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.terminate()
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
        self.processes.clear()
        if self.munged_pid is not None:
            try:
                os.kill(self.munged_pid, 15)
            except ProcessLookupError:
                pass
            self.munged_pid = None
        if ours:
            SYSTEM_CONF.unlink()
        if self.moved_conf is not None:
            self.moved_conf.rename(SYSTEM_CONF)
            self.moved_conf = None
        if self.lock is not None:
            self.lock.close()  # releases the flock
            self.lock = None


def _start_munged(cluster: LocalSlurm) -> None:
    """Start munged as the munge user unless a running one already answers."""
    if _munge_works():
        return
    run_dir = Path("/run/munge")
    run_dir.mkdir(parents=True, exist_ok=True)
    shutil.chown(run_dir, "munge", "munge")
    for sub in (Path("/var/log/munge"), Path("/var/lib/munge")):
        sub.mkdir(parents=True, exist_ok=True)
        shutil.chown(sub, "munge", "munge")
    if not Path("/etc/munge/munge.key").is_file():
        subprocess.run([_which("mungekey"), "--create"], check=False, timeout=60)
        shutil.chown("/etc/munge/munge.key", "munge", "munge")
    pidfile = run_dir / "munged.pid"
    run = subprocess.run(["runuser", "-u", "munge", "--", _which("munged"),
                          f"--pid-file={pidfile}"], text=True, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=60)
    if run.returncode != 0 or not _wait(_munge_works, 20):
        log = Path("/var/log/munge/munged.log")
        raise SlurmStartError(f"munged did not start (exit {run.returncode}): {run.stdout}\n"
                              + (log.read_text(errors="replace")[-4000:] if log.is_file() else ""))
    cluster.munged_pid = int(pidfile.read_text().split()[0])


def start(root: Path, timeout_s: float = 90) -> LocalSlurm:
    """Install (if missing) and start a single-node SLURM whose files live in ``root``.

    Parameters
    ----------
    root : Path
        An empty folder for slurm.conf, state, spool, logs and pid files.
    timeout_s : float
        Seconds to wait for the node to be idle.

    Returns
    -------
    LocalSlurm
        Call :meth:`LocalSlurm.stop` when done.

    Raises
    ------
    SlurmStartError
        A package, munged, slurmctld or slurmd failed; the message holds their logs.
    """
    install_packages()
    LOCK_FILE.parent.mkdir(parents=True, exist_ok=True)
    lock = open(LOCK_FILE, "a+")
    deadline = time.monotonic() + LOCK_TIMEOUT_S
    while True:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            break
        except BlockingIOError:
            if time.monotonic() > deadline:
                lock.close()
                raise SlurmStartError(f"another test SLURM held {LOCK_FILE} for {LOCK_TIMEOUT_S} s")
            time.sleep(2)
    root = Path(root)
    for sub in ("state", "spool"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    hardware = node_hardware()
    conf = SYSTEM_CONF
    cluster = LocalSlurm(root=root, conf=conf, cpus=int(hardware["CPUs"]),
                         real_memory_mb=int(hardware["RealMemory"]), lock=lock)
    conf.parent.mkdir(parents=True, exist_ok=True)
    if conf.is_file() and not conf.read_text().startswith(CONF_HEADER):
        cluster.moved_conf = conf.with_name(conf.name + ".moved-by-pidpipe-tests")
        conf.rename(cluster.moved_conf)
    cluster.text = slurm_conf(root, hardware, _free_ports(2))
    (root / "slurm.conf").write_text(cluster.text)
    conf.write_text(cluster.text)
    try:
        _start_munged(cluster)
        cluster._start("slurmctld", "-D", "-c", "-f", str(conf))
        if not _wait(lambda: cluster.command("scontrol", "ping").stdout.count("UP") > 0, 30):
            raise SlurmStartError("slurmctld does not answer scontrol ping")
        cluster._start("slurmd", "-D", "-N", "localhost", "-f", str(conf))
        if not _wait(lambda: cluster.node_state() == "idle", timeout_s):
            raise SlurmStartError(f"the node is not idle after {timeout_s:.0f} s "
                                  f"(sinfo: {cluster.node_state()})")
        for name, proc in cluster.processes.items():
            if proc.poll() is not None:
                raise SlurmStartError(f"{name} exited with {proc.returncode}")
    except (SlurmStartError, OSError, subprocess.SubprocessError) as exc:
        logs = cluster.logs()
        cluster.stop()
        raise SlurmStartError(f"local SLURM did not start: {exc}\n{logs}") from exc
    return cluster
