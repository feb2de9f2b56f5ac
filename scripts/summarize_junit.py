#!/usr/bin/env python3
"""Prints the closing line of the test run, 'tests: N passed, N failed, N skipped', from
the JUnit XML files catkin/rostest write. Exits 1 when no test ran at all."""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def main(root):
    passed = failed = skipped = 0
    for path in glob.glob(os.path.join(root, "**", "*.xml"), recursive=True):
        try:
            tree = ET.parse(path)
        except ET.ParseError:
            failed += 1
            print("unreadable test result (counted as a failure): %s" % path)
            continue
        # rostest writes a wrapper report (rostest-*.xml) around the test node's own report
        # (rosunit-*.xml): count the wrapper only when it failed (e.g. the launch broke).
        wrapper = os.path.basename(path).startswith("rostest-")
        for case in tree.iter("testcase"):
            if wrapper and case.find("failure") is None and case.find("error") is None:
                continue
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
            elif case.find("skipped") is not None or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
    print("tests: %d passed, %d failed, %d skipped" % (passed, failed, skipped))
    return 0 if passed + failed > 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
