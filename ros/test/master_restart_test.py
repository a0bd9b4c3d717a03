#!/usr/bin/python3
"""fdv_ros_node when its ROS master is killed and restarted (docs/ROS.md, "The master's restart").

    master_restart_test.py BUILD_DIR WORK_DIR

Starts roscore on a free loopback port and the node, kills roscore, and checks that the node logs
the loss as an ERROR; restarts roscore on the same port and checks that the node registers again
(its subscription to the events topic and its /diagnostics publication are known to the new
master, and the node says so in its log). Processes and steps as in node_replay_test.py: each in
its own process group, bounded, stopped on exit.
"""
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from node_replay_test import Processes, free_port, wait_until  # noqa: E402


def main():
    build, work_root = sys.argv[1], sys.argv[2]
    os.makedirs(work_root, exist_ok=True)
    work = tempfile.mkdtemp(dir=work_root)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1",
               ROS_HOME=work, ROS_LOG_DIR=os.path.join(work, "log"))
    procs = Processes(env, work)
    import rosgraph
    master = rosgraph.Master("/master_restart_test", master_uri=env["ROS_MASTER_URI"])

    def master_up():
        try:
            master.getPid()
            return True
        except Exception:
            return False

    def registered():
        try:
            publishers, subscribers, _ = master.getSystemState()
        except Exception:
            return False
        subs = {t: n for t, n in subscribers}
        pubs = {t: n for t, n in publishers}
        return "/fdv" in subs.get("/dvs/events", []) and "/fdv" in pubs.get("/diagnostics", [])

    try:
        roscore = procs.start("roscore", ["roscore", "-p", str(port)])
        wait_until(master_up, "roscore")
        node = procs.start("node", [os.path.join(build, "fdv_ros_node"), "__name:=fdv", "_width:=64",
                                    "_height:=48"])
        wait_until(registered, "the node's registration")

        procs.stop(roscore)
        wait_until(lambda: "lost the ROS master at" in procs.log("node"), "the node's ERROR on the master's loss")
        assert node.poll() is None, "the node exited when its master went away"

        procs.start("roscore2", ["roscore", "-p", str(port)])
        wait_until(master_up, "the restarted roscore")
        wait_until(registered, "the node's registration with the restarted master")
        # The node registers first and logs after, so the line may lag the registration.
        wait_until(lambda: "is back: publishers and subscribers registered again" in procs.log("node"),
                   "the node's log of the master's return")
        assert node.poll() is None
        print("the node registered again with the restarted master")
    except Exception:
        for name, _ in procs.started:
            print(f"--- {name} log (tail)\n" + procs.log(name)[-3000:], file=sys.stderr)
        raise
    finally:
        procs.stop_all()


if __name__ == "__main__":
    main()
