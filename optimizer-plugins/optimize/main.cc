// yamor-optimize: learns gaits with an optimizer plugin. See `yamor-optimize --help`.
#include <iostream>
#include <string>
#include <vector>

#include "optimizer-plugins/optimize/run.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return yamor::optimize::Run(args, std::cout, std::cerr, argv[0]);
}
