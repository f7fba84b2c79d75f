#ifndef __UTYPES_H__
#define __UTYPES_H__

#include "cc.h"

/* Object dictionary storage */

typedef struct
{
   uint16_t SyncMode;
   uint32_t CycleTime;
   uint16_t SyncModesSupported;
   uint32_t MinimumCycleTime;
   uint32_t CalcAndCopyTime;
   uint16_t CycleTimeTooSmall;
   uint8_t SyncError;
} _SyncManagerParameter;

typedef struct
{
   /* Inputs */
   int16_t AnalogInput[8];   /* 0x6401 */

   /* Outputs */
   int16_t AnalogOutput[2];  /* 0x6411 */

   /* Parameters */
   struct
   {
      uint32_t LocalErrorReaction;
      uint16_t SyncErrorCounterLimit;
   } ErrorSettings;          /* 0x10F1 */

   /* Sync Managers */
   _SyncManagerParameter SyncManagerOutput; /* 0x1C32 */
   _SyncManagerParameter SyncManagerInput;  /* 0x1C33 */
} _Objects;

extern _Objects Obj;

#endif /* __UTYPES_H__ */
