// pl_slam_evaluate: ATE / RPE / coverage of an estimated trajectory against ground truth,
// with an optional PNG plot and JSON report. All logic lives in pl_slam::eval (see
// include/pl_slam/eval/evaluate_cli.h) so the tests exercise the same code.
#include <iostream>
#include <string>
#include <vector>

#include "pl_slam/eval/evaluate_cli.h"

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return pl_slam::eval::RunEvaluateCli(args, std::cout, std::cerr);
}
