/* Time one process from its start to its exit, with the leanest spawn
 * the C library has (posix_spawn: glibc clones with CLONE_VM|CLONE_VFORK,
 * so no page tables are copied), and print the wall time in ms on
 * stdout. The process's own streams are the spawner's: its stderr
 * passes through to whoever reads ours.
 *
 *   spawn-time PROGRAM [ARG ...]
 *
 * scripts/peers-js.mjs runs `grmc derive` through it so that a run's
 * figure is the grmc process alone: node's own spawnSync (a fork of a
 * large process, pipes, an event loop) costs more than a small process
 * lives (docs/benchmarks.md, "The process figure and the spawner").
 * Built by scripts/peers-js.sh with the system's C compiler. */
#define _GNU_SOURCE
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <time.h>

extern char **environ;

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: spawn-time PROGRAM [ARG ...]\n");
        return 2;
    }
    struct timespec t0, t1;
    pid_t pid;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int err = posix_spawn(&pid, argv[1], NULL, NULL, argv + 1, environ);
    if (err != 0) {
        fprintf(stderr, "spawn-time: cannot start %s (error %d)\n", argv[1], err);
        return 2;
    }
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) {
        perror("spawn-time: waitpid");
        return 2;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) / 1e6;
    printf("%.4f\n", ms);
    if (!WIFEXITED(status)) return 2;
    return WEXITSTATUS(status);
}
