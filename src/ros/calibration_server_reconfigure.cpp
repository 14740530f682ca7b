// The calibration node's dynamic_reconfigure: the thresholds an operator tunes in the field (field_thresholds.h,
// cfg/Calibration.cfg) changed while the node runs, through dynamic_reconfigure's protocol (rqt_reconfigure,
// dynparam, dynamic_reconfigure's clients). The values of the ROS parameters read at start-up are the first state.
// A request with a value out of range is refused as a whole, with a warning saying what is allowed; the tools see
// the unchanged values in the reply and on ~parameter_updates.
#include <dynamic_reconfigure/ConfigDescription.h>
#include <dynamic_reconfigure/config_tools.h>

#include "insitu_calibration/CalibrationConfig.h"
#include "insitu_calibration/ros/calibration_server.h"

namespace insitu_calibration
{
void CalibrationServer::setupReconfigure()
{
  reconfigure_descriptions_publisher_ =
      private_nh_.advertise<dynamic_reconfigure::ConfigDescription>("parameter_descriptions", 1, true);
  reconfigure_updates_publisher_ = private_nh_.advertise<dynamic_reconfigure::Config>("parameter_updates", 1, true);
  reconfigure_descriptions_publisher_.publish(CalibrationConfig::__getDescriptionMessage__());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    reconfigure_updates_publisher_.publish(reconfigureState());
  }
  reconfigure_server_ = service_nh_.advertiseService("set_parameters", &CalibrationServer::reconfigureService, this);
}

dynamic_reconfigure::Config CalibrationServer::reconfigureState() const
{
  dynamic_reconfigure::Config values;
  for (const FieldThreshold& threshold : fieldThresholds())
  {
    const double value = threshold.get(thresholds_);
    if (threshold.range.integer)
      dynamic_reconfigure::ConfigTools::appendParameter(values, threshold.reconfigure_name, static_cast<int>(value));
    else
      dynamic_reconfigure::ConfigTools::appendParameter(values, threshold.reconfigure_name, value);
  }
  // Through the generated class: the reply and the updates carry its group states, as the tools expect.
  CalibrationConfig config = CalibrationConfig::__getDefault__();
  config.__fromMessage__(values);
  dynamic_reconfigure::Config state;
  config.__toMessage__(state);
  return state;
}

bool CalibrationServer::reconfigureService(dynamic_reconfigure::Reconfigure::Request& request,
                                           dynamic_reconfigure::Reconfigure::Response& response)
{
  std::lock_guard<std::mutex> lock(mutex_);
  FieldThresholds changed = thresholds_;
  std::vector<std::string> errors;
  const auto change = [&](const std::string& name, double value) {
    const FieldThreshold* threshold = findFieldThreshold(name);
    if (!threshold)
      return errors.push_back("there is no reconfigurable parameter " + name);
    if (const Status checked = checkParameter(name, value, threshold->range); !checked)
      return errors.push_back(checked.error().message());
    threshold->set(changed, value);
  };
  for (const auto& parameter : request.config.doubles)
    change(parameter.name, parameter.value);
  for (const auto& parameter : request.config.ints)
    change(parameter.name, parameter.value);
  if (errors.empty())
    if (const Status consistent = checkFieldThresholds(changed); !consistent)
      errors.push_back(consistent.error().message());
  if (errors.empty())
    applyThresholds(changed);
  for (const std::string& error : errors)
    ROS_WARN_STREAM("calibration_node: dynamic_reconfigure refused: "
                    << error
                    << "; the thresholds are unchanged. Set a value in the allowed range (rosrun "
                       "dynamic_reconfigure dynparam set "
                    << private_nh_.getNamespace() << " <parameter> <value>)");
  response.config = reconfigureState();
  reconfigure_updates_publisher_.publish(response.config);
  return true;
}

void CalibrationServer::applyThresholds(const FieldThresholds& thresholds)
{
  const double old_period_s = thresholds_.verify_period_s;
  thresholds_ = thresholds;
  survey_->setCameraOptions(thresholds_.cameras);
  // The parameter server shows the current values too, under the names read at start-up.
  for (const FieldThreshold& threshold : fieldThresholds())
    if (threshold.range.integer)
      private_nh_.setParam(threshold.parameter, static_cast<int>(threshold.get(thresholds_)));
    else
      private_nh_.setParam(threshold.parameter, threshold.get(thresholds_));
  if (thresholds_.verify_period_s == old_period_s)
    return;
  if (thresholds_.verify_period_s > 0.0)
  {
    verify_timer_.setPeriod(ros::WallDuration(thresholds_.verify_period_s));
    verify_timer_.start();
  }
  else
    verify_timer_.stop();
  ROS_INFO_STREAM("calibration_node: the watchdog checks the cameras "
                  << (thresholds_.verify_period_s > 0.0
                          ? "every " + formatParameterValue(thresholds_.verify_period_s) + " s"
                          : std::string("only on ~verify")));
}
}  // namespace insitu_calibration
