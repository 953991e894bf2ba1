//! The six `rcl_interfaces` parameter services of the node, served here rather than by
//! ros2-client so that `describe_parameters` states each parameter's doc, unit, range and
//! constraints from its declaration. ros2-client 0.12.1 answers `describe_parameters` with
//! "(description missing, not implemented)" and has no way to set a descriptor, so the node
//! starts it with `start_parameter_services(false)` and serves all six itself, through the node's
//! own parameter store (`Node::get_parameter`, `Node::set_parameter`): the same rules, the same
//! validator, the same `/parameter_events`.
//!
//! One difference from ros2-client: `set_parameters_atomically` checks every parameter first and
//! then sets them one by one, publishing one parameter event each (ros2-client publishes one for
//! all).

use super::params::{descriptor, ParameterRefused, Shared};
use crate::config::Parameter as Declared;
use anyhow::Context as _;
use futures::StreamExt;
use ros2_client::parameters::{raw, ParameterDescriptor, SetParametersResult};
use ros2_client::rcl_interfaces::{
    DescribeParametersRequest, DescribeParametersResponse, GetParameterTypesRequest,
    GetParameterTypesResponse, GetParametersRequest, GetParametersResponse, ListParametersRequest,
    ListParametersResponse, ListParametersResult, SetParametersAtomicallyResponse,
    SetParametersRequest, SetParametersResponse,
};
use ros2_client::{
    Message, Name, Node, Parameter, ParameterValue, QosProfile, ReadResult, RmwRequestId, Server,
    ServiceMapping, ServiceTypeName,
};

/// The servers of the six services.
pub(super) struct ParameterServices {
    get: Server<GetParametersRequest, GetParametersResponse>,
    get_types: Server<GetParameterTypesRequest, GetParameterTypesResponse>,
    set: Server<SetParametersRequest, SetParametersResponse>,
    set_atomically: Server<SetParametersRequest, SetParametersAtomicallyResponse>,
    list: Server<ListParametersRequest, ListParametersResponse>,
    describe: Server<DescribeParametersRequest, DescribeParametersResponse>,
    shared: Shared,
}

impl std::fmt::Debug for ParameterServices {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ParameterServices")
    }
}

fn server<Req, Resp>(
    node: &mut Node,
    service: &str,
    kind: &str,
) -> anyhow::Result<Server<Req, Resp>>
where
    Req: Message + Clone + 'static,
    Resp: Message + 'static,
{
    // As ros2-client's own: the enhanced (rmw_fastrtps) mapping, reliable, keep-last 1.
    let qos =
        QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 1 });
    let fqn = node.fully_qualified_name();
    let name =
        Name::new(&fqn, service).map_err(|e| anyhow::anyhow!("service {fqn}/{service}: {e:?}"))?;
    node.create_server(
        ServiceMapping::Enhanced,
        &name,
        &ServiceTypeName::new("rcl_interfaces", kind),
        qos.clone(),
        qos,
    )
    .with_context(|| format!("cannot offer the service {fqn}/{service}"))
}

impl ParameterServices {
    /// Offers the six services of `node` (started with `start_parameter_services(false)` and
    /// the parameters of `shared`).
    pub(super) fn offer(node: &mut Node, shared: &Shared) -> anyhow::Result<Self> {
        Ok(Self {
            get: server(node, "get_parameters", "GetParameters")?,
            get_types: server(node, "get_parameter_types", "GetParameterTypes")?,
            set: server(node, "set_parameters", "SetParameters")?,
            set_atomically: server(node, "set_parameters_atomically", "SetParametersAtomically")?,
            list: server(node, "list_parameters", "ListParameters")?,
            describe: server(node, "describe_parameters", "DescribeParameters")?,
            shared: shared.clone(),
        })
    }

    /// Answers requests until dropped.
    pub(super) async fn serve(&self, node: &Node) {
        let mut get = self.get.receive_request_stream();
        let mut get_types = self.get_types.receive_request_stream();
        let mut set = self.set.receive_request_stream();
        let mut set_atomically = self.set_atomically.receive_request_stream();
        let mut list = self.list.receive_request_stream();
        let mut describe = self.describe.receive_request_stream();
        loop {
            futures::select! {
                r = get.select_next_some() => {
                    respond(&self.get, r, |q| get_values(node, &q)).await;
                }
                r = get_types.select_next_some() => {
                    respond(&self.get_types, r, |q| get_types_of(node, &q)).await;
                }
                r = set.select_next_some() => {
                    respond(&self.set, r, |q| set_each(node, q)).await;
                }
                r = set_atomically.select_next_some() => {
                    respond(&self.set_atomically, r, |q| set_all(node, &self.shared, q)).await;
                }
                r = list.select_next_some() => {
                    respond(&self.list, r, |q| list_names(node, &q)).await;
                }
                r = describe.select_next_some() => {
                    respond(&self.describe, r, |q| describe_names(node, &q)).await;
                }
            }
        }
    }
}

/// Answers one request of `server` with `answer`, logging what fails.
async fn respond<Req, Resp>(
    server: &Server<Req, Resp>,
    request: ReadResult<(RmwRequestId, Req)>,
    answer: impl FnOnce(Req) -> Resp,
) where
    Req: Message + 'static,
    Resp: Message + 'static,
{
    match request {
        Ok((id, req)) => {
            if let Err(e) = server.async_send_response(id, answer(req)).await {
                log::warn!("a parameter service response was not sent: {e:?}");
            }
        }
        Err(e) => log::warn!("a parameter service request did not decode: {e:?}"),
    }
}

fn value_of(node: &Node, name: &str) -> ParameterValue {
    node.get_parameter(name).unwrap_or(ParameterValue::NotSet)
}

fn get_values(node: &Node, req: &GetParametersRequest) -> GetParametersResponse {
    GetParametersResponse {
        values: req.names.iter().map(|n| value_of(node, n).into()).collect(),
    }
}

fn get_types_of(node: &Node, req: &GetParameterTypesRequest) -> GetParameterTypesResponse {
    GetParameterTypesResponse {
        values: req
            .names
            .iter()
            .map(|n| ParameterValue::to_parameter_type_raw(&value_of(node, n)))
            .collect(),
    }
}

fn result(r: SetParametersResult) -> raw::SetParametersResult {
    r.into()
}

fn set_each(node: &Node, req: SetParametersRequest) -> SetParametersResponse {
    SetParametersResponse {
        results: req
            .parameter
            .into_iter()
            .map(|p| {
                let Parameter { name, value } = Parameter::from(p);
                result(node.set_parameter(&name, value))
            })
            .collect(),
    }
}

fn set_all(
    node: &Node,
    shared: &Shared,
    req: SetParametersRequest,
) -> SetParametersAtomicallyResponse {
    let params: Vec<Parameter> = req.parameter.into_iter().map(Parameter::from).collect();
    let checked = params
        .iter()
        .try_for_each(|p| acceptable(node, shared, p))
        .map_err(|e| e.to_string());
    let outcome = checked.and_then(|()| {
        params
            .into_iter()
            .try_for_each(|Parameter { name, value }| node.set_parameter(&name, value))
    });
    SetParametersAtomicallyResponse {
        result: result(outcome),
    }
}

/// Whether the node's store would take `p` on its own: declared, of its type, and valid (the
/// store's rules, then the validator it was given, as ros2-client's `set_atomically` checks).
fn acceptable(node: &Node, shared: &Shared, p: &Parameter) -> Result<(), ParameterRefused> {
    let Some(current) = node.get_parameter(&p.name) else {
        return Err(ParameterRefused::Undeclared {
            name: p.name.clone(),
        });
    };
    if std::mem::discriminant(&current) != std::mem::discriminant(&p.value)
        && !matches!(p.value, ParameterValue::NotSet)
    {
        return Err(ParameterRefused::TypeChange {
            name: p.name.clone(),
            from: format!("{:?}", current.to_parameter_type()),
            to: format!("{:?}", p.value.to_parameter_type()),
        });
    }
    if p.name == "use_sim_time" {
        return match p.value {
            ParameterValue::Boolean(_) => Ok(()),
            _ => Err(ParameterRefused::NotBoolean {
                name: p.name.clone(),
            }),
        };
    }
    shared.check(&p.name, &p.value).map(|_| ())
}

fn list_names(node: &Node, req: &ListParametersRequest) -> ListParametersResponse {
    ListParametersResponse {
        result: list(&node.list_parameters(), &req.prefixes, req.depth),
    }
}

/// `ListParameters` as rclcpp answers it: with no prefixes, the names with fewer than `depth`
/// dots (`depth` 0: all); otherwise the names equal to a prefix or under `prefix.` within
/// `depth` further levels; and the namespaces of the names listed.
fn list(names: &[String], prefixes: &[String], depth: u64) -> ListParametersResult {
    let within_depth = |s: &str| depth == 0 || (s.matches('.').count() as u64) < depth;
    let mut out = ListParametersResult {
        names: vec![],
        prefixes: vec![],
    };
    for name in names {
        let get_all = prefixes.is_empty() && within_depth(name);
        let under_prefix = prefixes.iter().any(|prefix| {
            name == prefix
                || name
                    .strip_prefix(prefix.as_str())
                    .and_then(|rest| rest.strip_prefix('.'))
                    .is_some_and(|rest| within_depth(&format!(".{rest}")))
        });
        if get_all || under_prefix {
            out.names.push(name.clone());
            if let Some((namespace, _)) = name.rsplit_once('.') {
                if !out.prefixes.iter().any(|p| p == namespace) {
                    out.prefixes.push(namespace.to_string());
                }
            }
        }
    }
    out
}

fn describe_names(node: &Node, req: &DescribeParametersRequest) -> DescribeParametersResponse {
    DescribeParametersResponse {
        values: req
            .names
            .iter()
            .map(
                |name| match (Declared::find(name), node.get_parameter(name)) {
                    (Some(declared), Some(_)) => descriptor(declared),
                    (None, Some(value)) => ParameterDescriptor::from_value(name, &value).into(),
                    (_, None) => ParameterDescriptor::unknown(name).into(),
                },
            )
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn lists_as_rclcpp_does() {
        let all = names(&["objective", "a.b", "a.b.c", "use_sim_time"]);
        let r = list(&all, &[], 0);
        assert_eq!(r.names, all);
        assert_eq!(r.prefixes, names(&["a", "a.b"]));
        let r = list(&all, &[], 1);
        assert_eq!(r.names, names(&["objective", "use_sim_time"]));
        // As rclcpp counts: the dots of the name after the prefix, its own separator included.
        assert!(list(&all, &names(&["a"]), 1).names.is_empty());
        let r = list(&all, &names(&["a"]), 2);
        assert_eq!(r.names, names(&["a.b"]));
        assert_eq!(
            list(&all, &names(&["a"]), 0).names,
            names(&["a.b", "a.b.c"])
        );
    }
}
