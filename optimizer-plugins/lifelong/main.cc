// yamor-lifelong: keeps one robot walking for life. See `yamor-lifelong --help`.
#include <iostream>
#include <string>
#include <vector>

#include "optimizer-plugins/lifelong/run.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return yamor::lifelong::Run(args, std::cout, std::cerr, argv[0]);
}
