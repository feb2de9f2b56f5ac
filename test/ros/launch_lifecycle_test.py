#!/usr/bin/env python3
"""rostest node: pl_slam's process lifecycle under roslaunch, on the test's own master.

1. A configuration with a misspelt key: stereo_slam_node exits non-zero within
   ~node_exit_timeout s with one FATAL line naming the key.
2. The same YAML through pl_slam.launch (standalone and nodelet, required:=true): roslaunch
   reports the death and stops on its own.
3. The typo fixed, launched again on the same master (the bad key is still on the parameter
   server from step 2): it starts, because the launch file clears the node's namespace.
"""
import os
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import rosgraph
import rospkg
import rostest

PKG = "pl_slam"
TYPO_KEY = "input_warning_priod"  # input_warning_period, misspelt


def _config(tmp, typo):
    src = os.path.join(rospkg.RosPack().get_path(PKG), "config", "synthetic.yaml")
    with open(src) as f:
        text = f.read()
    if typo:
        text += "\n%s: 2.0\n" % TYPO_KEY
    path = os.path.join(tmp, "with_typo.yaml" if typo else "fixed.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def _run(cmd, timeout):
    """Runs cmd in its own process group; (returncode or None on timeout, output, seconds)."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
        return proc.returncode, out, time.monotonic() - start
    except subprocess.TimeoutExpired:
        _stop(proc)
        out, _ = proc.communicate()
        return None, out, time.monotonic() - start


def _stop(proc):
    """SIGINT to the process group we started (roslaunch and its children), then SIGKILL."""
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGINT)
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


class LaunchLifecycle(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="pl_slam_launch_")
        cls.bad = _config(cls.tmp, typo=True)
        cls.good = _config(cls.tmp, typo=False)
        cls.master = rosgraph.Master("/launch_lifecycle_test")
        cls.node_exit_timeout = float(os.environ.get("PL_SLAM_NODE_EXIT_TIMEOUT", "5"))

    def _launch(self, config, standalone, timeout):
        return _run(["roslaunch", PKG, "pl_slam.launch", "config:=" + config,
                     "standalone:=" + ("true" if standalone else "false"), "required:=true",
                     "output:=screen", "camera_mount:="], timeout)

    def test_1_bad_config_makes_the_node_exit(self):
        # The parameters as the launch file would load them, then the bare node.
        subprocess.check_call(["rosparam", "load", self.bad, "/pl_slam_probe"])
        rc, out, seconds = _run(["rosrun", PKG, "stereo_slam_node", "__name:=pl_slam_probe"],
                                timeout=60)
        print("[launch_lifecycle] stereo_slam_node exited with %s after %.1f s:\n%s"
              % (rc, seconds, out))
        subprocess.call(["rosparam", "delete", "/pl_slam_probe"])
        self.assertIsNotNone(rc, "stereo_slam_node did not exit after refusing its parameters")
        self.assertNotEqual(rc, 0, "a refused start must exit non-zero")
        self.assertLess(seconds, self.node_exit_timeout)
        fatal = [l for l in out.splitlines() if "FATAL" in l]
        self.assertEqual(len(fatal), 1, out)
        self.assertIn(TYPO_KEY, fatal[0])

    def test_2_roslaunch_reports_the_refusal_and_stops(self):
        for standalone in (True, False):
            rc, out, seconds = self._launch(self.bad, standalone, timeout=90)
            print("[launch_lifecycle] roslaunch (standalone=%s) ended with %s after %.1f s"
                  % (standalone, rc, seconds))
            self.assertIsNotNone(rc, "roslaunch kept running after pl_slam refused to start "
                                 "(standalone=%s):\n%s" % (standalone, out))
            self.assertIn("refusing to start", out)
            self.assertIn("process has died", out, out)
            self.assertIn("required process", out.lower(), out)
        # What the failed launches left on the parameter server: the typo.
        self.assertTrue(self.master.hasParam("/pl_slam/" + TYPO_KEY))

    def test_3_relaunch_after_fixing_the_typo_starts(self):
        if not self.master.hasParam("/pl_slam/" + TYPO_KEY):
            self.master.setParam("/pl_slam/" + TYPO_KEY, 2.0)  # as a failed launch leaves it
        for standalone in (True, False):
            proc = subprocess.Popen(
                ["roslaunch", PKG, "pl_slam.launch", "config:=" + self.good,
                 "standalone:=" + ("true" if standalone else "false"), "required:=true",
                 "camera_mount:="],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                start_new_session=True)
            started = False
            try:
                deadline = time.monotonic() + 60
                while time.monotonic() < deadline and proc.poll() is None:
                    try:
                        self.master.lookupService("/pl_slam/save_map")
                        started = True
                        break
                    except rosgraph.MasterError:
                        time.sleep(0.2)
                stale = self.master.hasParam("/pl_slam/" + TYPO_KEY)
            finally:
                _stop(proc)
                out, _ = proc.communicate()
            self.assertTrue(started, "pl_slam did not start after the typo was fixed "
                            "(standalone=%s):\n%s" % (standalone, out))
            self.assertFalse(stale, "the misspelt key is still on the parameter server")
            # Let the master forget the stopped node's services before the next launch.
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:
                try:
                    self.master.lookupService("/pl_slam/save_map")
                    time.sleep(0.2)
                except rosgraph.MasterError:
                    break
            self.master.setParam("/pl_slam/" + TYPO_KEY, 2.0)  # stale again for the next run


if __name__ == "__main__":
    rostest.rosrun(PKG, "launch_lifecycle", LaunchLifecycle, sys.argv)
