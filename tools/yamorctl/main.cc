// yamorctl: the command-line client of yamord. See `yamorctl --help`.
#include <iostream>
#include <string>
#include <vector>

#include "tools/yamorctl/yamorctl.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return yamor::yamorctl::Run(args, std::cout, std::cerr);
}
