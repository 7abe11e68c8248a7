// cmmd: the control daemon (placeholder until the service lands in issue 6).
#include <iostream>

int main() {
  std::cout << "cmmd: not yet\n";
  return 1;
}
