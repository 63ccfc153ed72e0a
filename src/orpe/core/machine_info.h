// A description of the machine a program runs on, for the provenance of results (summary.json of
// `orpe run`, `orpe report`): figures measured on a loaded 2-core machine are not those of a
// workstation, and a reader should be able to tell.
#pragma once

#include <string>

namespace orpe {

struct MachineInfo {
  std::string hostname;
  std::string cpu_model;      ///< /proc/cpuinfo "model name" (empty when unknown)
  unsigned logical_cpus = 0;  ///< std::thread::hardware_concurrency
  std::string os;             ///< uname: sysname release machine
  double load_1min = -1;      ///< getloadavg, at the time of the call; -1 when unavailable
  double memory_gb = 0;       ///< physical memory
};

MachineInfo describe_machine();

}  // namespace orpe
