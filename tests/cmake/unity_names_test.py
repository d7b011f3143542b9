#!/usr/bin/env python3
"""Tests of cmake/unity_names.py: what it names as a clash of file-local names, and what not."""
import os
import subprocess
import sys
import tempfile
import textwrap
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "cmake", "unity_names.py")


def check(*files, targets=None, missing=False):
    """Runs the script over `files` (source texts), each of target `targets[i]` (all of one target
    "t" when not given), and, with `missing`, a listed file that does not exist:
    (status, stdout + stderr)."""
    with tempfile.TemporaryDirectory() as d:
        lines = []
        for i, text in enumerate(files):
            path = os.path.join(d, f"f{i}.cpp")
            with open(path, "w", encoding="utf-8") as f:
                f.write(textwrap.dedent(text))
            lines.append(f"{targets[i] if targets else 't'}\t{path}")
        if missing:
            lines.append(f"t\t{d}/missing.cpp")
        listing = os.path.join(d, "list.txt")
        with open(listing, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
        r = subprocess.run([sys.executable, SCRIPT, listing], capture_output=True, text=True)
        return r.returncode, r.stdout + r.stderr


class UnityNames(unittest.TestCase):
    def test_one_function_in_two_anonymous_namespaces_is_named_with_both_lines(self):
        a = """
            #include <string>
            namespace {
            // a comment with namespace { and a brace }
            int column(const std::vector<std::string>& header, const std::string& name) {
              return 0;
            }
            }  // namespace
            """
        b = """
            namespace {
            const char* text = "} namespace {";
            std::size_t column(const std::vector<std::string>& names, const std::string& name) { return 1; }
            }
            """
        rc, out = check(a, b)
        self.assertEqual(rc, 1, out)
        self.assertIn("'column'", out)
        self.assertIn("f0.cpp:5:", out)
        self.assertIn("f1.cpp:4:", out)

    def test_types_constants_and_statics_clash_too(self):
        rc, out = check("namespace { struct Ref { int k; }; constexpr double kPi = 3.14; }\n"
                        "static int helper(int x) { return x; }\n",
                        "namespace { struct Ref { double k; }; }\nnamespace { constexpr double kPi = 3.1; }\n"
                        "static int helper(int y) { return y; }\n")
        self.assertEqual(rc, 1, out)
        for name in ("'Ref'", "'kPi'", "'helper'"):
            self.assertIn(name, out)

    def test_overloads_identical_aliases_named_namespaces_and_tests_are_not_clashes(self):
        a = """
            namespace fs = std::filesystem;
            namespace {
            using Key = std::tuple<int, int>;
            int twice(int x) { return 2 * x; }
            TEST(Suite, One) { EXPECT_EQ(twice(1), 2); }
            }
            namespace first { namespace { struct Ref {}; } }
            """
        b = """
            namespace fs = std::filesystem;
            namespace {
            using Key = std::tuple<int, int>;
            double twice(double x) { return 2 * x; }
            TEST(Suite, Two) { EXPECT_EQ(twice(1.0), 2.0); }
            }
            namespace second { namespace { struct Ref {}; } }
            """
        rc, out = check(a, b)
        self.assertEqual(rc, 0, out)
        self.assertIn("0 name(s)", out)

    def test_a_using_declaration_beside_a_constant_of_its_name_clashes(self):
        rc, out = check("namespace { using numen::test::kDeg; }\n",
                        "namespace { using numen::test::kDeg; }\n",
                        "namespace { constexpr double kDeg = numen::test::kDeg; }\n")
        self.assertEqual(rc, 1, out)
        self.assertIn("'kDeg'", out)
        self.assertEqual(check("namespace { using numen::test::kDeg; }\n",
                               "namespace { using numen::test::kDeg; }\n")[0], 0)

    def test_an_alias_of_another_type_clashes(self):
        rc, out = check("namespace { using Key = std::tuple<int, int>; }\n",
                        "namespace { using Key = std::tuple<int, int, int>; }\n")
        self.assertEqual(rc, 1, out)
        self.assertIn("'Key'", out)
        rc, out = check("namespace { typedef int Id; }\n", "namespace { typedef long Id; }\n")
        self.assertEqual(rc, 1, out)
        self.assertIn("'Id'", out)
        self.assertEqual(check("namespace { typedef int Id; }\n", "namespace { typedef int Id; }\n")[0], 0)

    def test_the_same_name_in_two_targets_is_not_a_clash(self):
        helper = "namespace { int helper() { return 0; } }\n"
        rc, out = check(helper, helper, targets=["a", "b"])
        self.assertEqual(rc, 0, out)
        self.assertEqual(check(helper, helper)[0], 1)

    def test_an_unreadable_file_is_an_error_naming_it(self):
        rc, out = check(missing=True)
        self.assertEqual(rc, 2)
        self.assertIn("missing.cpp", out)

if __name__ == "__main__":
    unittest.main()
