// Raw clients of the standard gRPC services yamord hosts (grpc.health.v1 and
// server reflection), as grpcurl uses them. Debian ships neither service's
// C++ client headers, so requests are hand-encoded protobuf bytes and
// replies are read with protobuf's UnknownFieldSet (field numbers from the
// public service definitions).
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/impl/client_unary_call.h>
#include <grpcpp/support/sync_stream.h>

namespace yamor::host::testing {

inline grpc::ByteBuffer ToBuffer(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

inline std::string FromBuffer(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  (void)buffer.Dump(&slices);
  std::string out;
  for (const grpc::Slice& s : slices) out.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return out;
}

// A length-delimited protobuf field: tag, varint length, bytes.
inline std::string LengthDelimited(int field, const std::string& bytes) {
  std::string out(1, static_cast<char>((field << 3) | 2));
  std::size_t n = bytes.size();
  do {
    uint8_t b = n & 0x7f;
    n >>= 7;
    if (n) b |= 0x80;
    out.push_back(static_cast<char>(b));
  } while (n);
  return out + bytes;
}

inline void SetDeadline(grpc::ClientContext& context, int seconds = 10) {
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
}

/// grpc.health.v1.Health/Check for `service` ("" = the server); `status` gets
/// the ServingStatus number (1 = SERVING, 2 = NOT_SERVING).
inline grpc::Status HealthCheck(const std::shared_ptr<grpc::Channel>& channel,
                                const std::string& service, int* status) {
  grpc::ClientContext context;
  SetDeadline(context);
  const grpc::internal::RpcMethod method("/grpc.health.v1.Health/Check",
                                         grpc::internal::RpcMethod::NORMAL_RPC);
  grpc::ByteBuffer response;
  // HealthCheckRequest { string service = 1; }
  const grpc::Status result = grpc::internal::BlockingUnaryCall<grpc::ByteBuffer, grpc::ByteBuffer>(
      channel.get(), method, &context,
      ToBuffer(service.empty() ? std::string() : LengthDelimited(1, service)), &response);
  if (!result.ok()) return result;
  // HealthCheckResponse { ServingStatus status = 1; } (0 is omitted on the wire)
  google::protobuf::UnknownFieldSet fields;
  fields.ParseFromString(FromBuffer(response));
  *status = 0;
  for (int i = 0; i < fields.field_count(); ++i) {
    if (fields.field(i).number() == 1) *status = static_cast<int>(fields.field(i).varint());
  }
  return result;
}

/// One ServerReflectionInfo exchange: sends `request` bytes, returns the
/// reply's fields.
inline grpc::Status ReflectionExchange(const std::shared_ptr<grpc::Channel>& channel,
                                       const std::string& request,
                                       google::protobuf::UnknownFieldSet* reply) {
  grpc::ClientContext context;
  SetDeadline(context);
  const grpc::internal::RpcMethod method(
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
      grpc::internal::RpcMethod::BIDI_STREAMING);
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          channel.get(), method, &context));
  stream->Write(ToBuffer(request));
  stream->WritesDone();
  grpc::ByteBuffer response;
  while (stream->Read(&response)) reply->ParseFromString(FromBuffer(response));
  return stream->Finish();
}

/// The services a server lists through reflection (grpcurl list).
inline grpc::Status ListServices(const std::shared_ptr<grpc::Channel>& channel,
                                 std::vector<std::string>* names) {
  google::protobuf::UnknownFieldSet reply;
  // ServerReflectionRequest { string list_services = 7; }
  const grpc::Status status = ReflectionExchange(channel, LengthDelimited(7, "*"), &reply);
  if (!status.ok()) return status;
  for (int i = 0; i < reply.field_count(); ++i) {
    // ServerReflectionResponse { ListServiceResponse list_services_response = 6; }
    if (reply.field(i).number() != 6) continue;
    google::protobuf::UnknownFieldSet list;
    list.ParseFromString(reply.field(i).length_delimited());
    for (int j = 0; j < list.field_count(); ++j) {
      // ListServiceResponse { repeated ServiceResponse service = 1; } ServiceResponse { string name = 1; }
      google::protobuf::UnknownFieldSet service;
      service.ParseFromString(list.field(j).length_delimited());
      for (int k = 0; k < service.field_count(); ++k) {
        if (service.field(k).number() == 1) names->push_back(service.field(k).length_delimited());
      }
    }
  }
  return status;
}

/// The file descriptors reflection returns for `symbol` (grpcurl describe).
inline grpc::Status DescribeSymbol(const std::shared_ptr<grpc::Channel>& channel,
                                   const std::string& symbol,
                                   std::vector<google::protobuf::FileDescriptorProto>* files) {
  google::protobuf::UnknownFieldSet reply;
  // ServerReflectionRequest { string file_containing_symbol = 4; }
  const grpc::Status status = ReflectionExchange(channel, LengthDelimited(4, symbol), &reply);
  if (!status.ok()) return status;
  for (int i = 0; i < reply.field_count(); ++i) {
    // file_descriptor_response = 4 { repeated bytes file_descriptor_proto = 1; }
    if (reply.field(i).number() != 4) continue;
    google::protobuf::UnknownFieldSet response;
    response.ParseFromString(reply.field(i).length_delimited());
    for (int j = 0; j < response.field_count(); ++j) {
      google::protobuf::FileDescriptorProto file;
      if (file.ParseFromString(response.field(j).length_delimited())) files->push_back(file);
    }
  }
  return status;
}

}  // namespace yamor::host::testing
