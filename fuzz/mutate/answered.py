"""What the mutation scripts share: a command run once, its answer."""
import subprocess


def answered(cmd, timeout):
    """`cmd`'s exit code and standard error (stdout discarded), or
    ("timeout", "") once it runs past `timeout` seconds: a hang."""
    try:
        r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", ""
    return r.returncode, r.stderr.decode(errors="replace")


def failed(rc, err):
    """Whether an answer is no answer: a panic, an abort, a signal or a
    hang (exit codes 0, 1 and 2 are answers)."""
    return rc not in (0, 1, 2) or "panicked" in err
