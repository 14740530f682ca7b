// CPU time of the calling thread, for stage times and benchmarks: what the work costs on one core, whatever else
// runs on the machine.
#ifndef INSITU_CALIBRATION_CPU_TIME_H
#define INSITU_CALIBRATION_CPU_TIME_H

#include <ctime>

namespace insitu_calibration
{
// Milliseconds of CPU time this thread has used.
inline double threadCpuMs()
{
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

// CPU milliseconds since `start`, a threadCpuMs() value.
inline double cpuMsSince(double start)
{
  return threadCpuMs() - start;
}

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_CPU_TIME_H
