"""Wall time of a whole process, started the way `ezy bench` starts its
own (posix_spawn, stdout and stderr to /dev/null, no shell in between):

    python spawn_time.py REPS CMD [ARG ...]

starts CMD REPS times, one after the other, and prints the median wall
time [s] from the spawn to the end of the wait. A shell's fork around
each start (bash's `EPOCHREALTIME` before and after) added about 0.3-1 ms
to every process on the reference machine, more than a compiled peer's
whole integration, so every process of the table is timed here alike.
Exits with an error if a start fails.
"""

import os
import statistics
import sys
import time


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit("usage: python spawn_time.py REPS CMD [ARG ...]")
    reps, cmd = int(sys.argv[1]), sys.argv[2:]
    null = os.open(os.devnull, os.O_WRONLY)
    actions = [(os.POSIX_SPAWN_DUP2, null, 1), (os.POSIX_SPAWN_DUP2, null, 2)]
    times = []
    for _ in range(max(reps, 1)):
        t0 = time.perf_counter()
        pid = os.posix_spawnp(cmd[0], cmd, os.environ, file_actions=actions)
        _, status = os.waitpid(pid, 0)
        times.append(time.perf_counter() - t0)
        code = os.waitstatus_to_exitcode(status)
        if code != 0:
            sys.exit(f"{' '.join(cmd)}: exit status {code}")
    print(f"{statistics.median(times):.6f}")


if __name__ == "__main__":
    main()
