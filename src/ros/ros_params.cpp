#include "ros_params.h"

#include <ros/param.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace spool_vision
{
namespace
{
ParamValue toParamValue(const std::string& key, XmlRpc::XmlRpcValue& value)
{
  switch (value.getType())
  {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value);
    case XmlRpc::XmlRpcValue::TypeInt:
      return static_cast<int>(value);
    case XmlRpc::XmlRpcValue::TypeDouble:
      return static_cast<double>(value);
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(value);
    default:
      throw ParamError(
          key, "expected a number or a word, got " + value.toXml() + "; allowed: " + findParamSpec(key)->allowed());
  }
}

}  // namespace

void loadParamsFromRos(const ros::NodeHandle& pnh, const std::set<std::string>& ros_keys, DetectorParams& params)
{
  XmlRpc::XmlRpcValue all;
  if (pnh.getParam(pnh.getNamespace(), all) && all.getType() == XmlRpc::XmlRpcValue::TypeStruct)
  {
    for (auto& [key, value] : all)
    {
      // Sub-namespaces belong to others (image_transport publisher settings such as
      // ~debug_image/compressed/...), so only plain values are held to the key list.
      if (value.getType() == XmlRpc::XmlRpcValue::TypeStruct)
        continue;
      if (ros_keys.count(key))
        continue;
      if (!findParamSpec(key))
        throw ParamError(key, "unknown parameter (neither a detector key nor a node option)");
      setParam(params, key, toParamValue(key, value));
    }
  }
  validateParams(params);
}

void setRosParam(const ros::NodeHandle& pnh, const std::string& key, const ParamValue& value)
{
  if (const auto* b = std::get_if<bool>(&value))
    pnh.setParam(key, *b);
  else if (const auto* i = std::get_if<int>(&value))
    pnh.setParam(key, *i);
  else if (const auto* d = std::get_if<double>(&value))
    pnh.setParam(key, *d);
  else
    pnh.setParam(key, std::get<std::string>(value));
}

std::string refusalMessage(const std::string& node_name, const std::exception& error)
{
  const auto* param = dynamic_cast<const ParamError*>(&error);
  if (!param)
    return error.what();
  return std::string(error.what()) + ". Fix it in the YAML you start with (`roslaunch spool_vision " +
         "spool_detector.launch config:=FILE`, which clears " + node_name +
         "'s parameters before loading it), or delete a value left by an earlier run: `rosparam delete " + node_name +
         "/" + param->key() + "`";
}

}  // namespace spool_vision
