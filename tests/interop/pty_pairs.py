#!/usr/bin/env python3
"""Opens N pseudo-terminal pairs and runs a command with them (the node-canopen interop tests).

Usage: pty_pairs.py N -- COMMAND [ARG...]

Each pair's slave is set raw (no echo, no line editing, no CR/LF translation) before anything
is sent, so bytes written on the master before numen opens the slave are not echoed back. The
command inherits, per pair, the master, a duplicate of it for writing (one file descriptor per
libuv stream) and the slave, which it keeps open so that the master never sees a hang-up
between two numen processes on the same line. They are described in the environment as
NUMEN_INTEROP_PTYS, a JSON list of {"path", "master", "writer", "slave"}.

One pair per numen process: numen's SerialBus takes the line exclusively (TIOCEXCL), and the
flag outlives its close while another descriptor of the slave stays open.
"""
import json
import os
import pty
import sys
import tty


def main(argv):
    if len(argv) < 4 or argv[2] != "--" or not argv[1].isdigit() or int(argv[1]) < 1:
        sys.stderr.write("usage: pty_pairs.py N -- COMMAND [ARG...]\n")
        return 2
    ptys = []
    for _ in range(int(argv[1])):
        master, slave = pty.openpty()
        tty.setraw(slave)
        writer = os.dup(master)
        for fd in (master, writer, slave):
            os.set_inheritable(fd, True)
        ptys.append({"path": os.ttyname(slave), "master": master, "writer": writer,
                     "slave": slave})
    os.environ["NUMEN_INTEROP_PTYS"] = json.dumps(ptys)
    os.execvp(argv[3], argv[3:])


if __name__ == "__main__":
    sys.exit(main(sys.argv))
