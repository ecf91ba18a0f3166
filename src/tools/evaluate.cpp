// evaluate: not implemented yet.
#include <iostream>

int main() {
  std::cerr << "evaluate: not implemented yet\n";
  return 1;
}
