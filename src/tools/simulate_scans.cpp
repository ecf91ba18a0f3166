// simulate_scans: not implemented yet.
#include <iostream>

int main() {
  std::cerr << "simulate_scans: not implemented yet\n";
  return 1;
}
