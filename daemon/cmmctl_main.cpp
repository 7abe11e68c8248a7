// cmmctl: the command-line client of cmmd (placeholder until the client lands in issue 6).
#include <iostream>

int main() {
  std::cout << "cmmctl: not yet\n";
  return 1;
}
