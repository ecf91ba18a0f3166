// novelty_detect: not implemented yet.
#include <iostream>

int main() {
  std::cerr << "novelty_detect: not implemented yet\n";
  return 1;
}
