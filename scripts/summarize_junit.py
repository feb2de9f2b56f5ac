#!/usr/bin/env python3
"""Prints the closing line of the test run, 'tests: N passed, N failed, N skipped', from
the JUnit XML files catkin/rostest write, after the name and the first lines of the message of
every failed test case (so a CI log's tail says what failed). Exits 1 when no test ran at all."""
import glob
import os
import sys
import xml.etree.ElementTree as ET


MESSAGE_LINES = 12


def describe(path, case):
    """'FAILED name (file): message', the message cut to its first MESSAGE_LINES lines."""
    bad = case.find("failure")
    if bad is None:
        bad = case.find("error")
    text = "\n".join(filter(None, [bad.get("message", ""), bad.text or ""])).strip()
    lines = [l for l in text.splitlines() if l.strip()][:MESSAGE_LINES]
    name = ".".join(filter(None, [case.get("classname", ""), case.get("name", "")]))
    return "FAILED %s (%s)\n%s" % (name, os.path.basename(path),
                                   "\n".join("    " + l for l in lines))


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
                print(describe(path, case))
            elif case.find("skipped") is not None or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
    print("tests: %d passed, %d failed, %d skipped" % (passed, failed, skipped))
    return 0 if passed + failed > 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
